"""``mmplan reproduce``: the published numbers with their references (:mod:`.published`),
the runs (:mod:`.runs`, :mod:`.run`), their evaluation (:mod:`.evaluate`) and the tables
(:mod:`.table`)."""
