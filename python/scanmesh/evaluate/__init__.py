"""Judging a mesh: the true surface of a CAD part, the virtual digitizer that scans it, and
the holdout error that judges a method without one."""
