"""Data shipped with scanmesh: the embedded demo scan and its true surface (see ATTRIBUTION.md)."""
