"""Torque limits of the extended-Jacobian planner: the virtual control ([PajakPajak] eqs.
(20)-(31), [Pajak] eqs. (13)-(22)): safety zone and growth laws (:mod:`.virtual_control`),
the per-step decision (:mod:`.decision`, symbolic form :mod:`.decision_symbolic`) and the
compiled feedback mode (:mod:`.feedback`)."""
