"""Reconstruction on a Dask cluster, for scans larger than one machine's memory (work in
progress: the parts and the face blocks are the interface between its modules)."""
