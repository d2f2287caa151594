"""Fleet batches: the single-recording tools over many recordings on Dask distributed (see README.md)."""
