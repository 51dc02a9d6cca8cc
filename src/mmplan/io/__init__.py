"""Plan folders: written atomically, read back (:mod:`.plan_folder`)."""

from mmplan.io.plan_folder import read_plan, read_summary, read_trajectory_csv, write_plan

__all__ = ["read_plan", "read_summary", "read_trajectory_csv", "write_plan"]
