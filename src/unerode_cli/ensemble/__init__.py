"""Ensembles of possible pasts (000): sweeps of parameters sampled and run as independent members on
dask.distributed, and the statistics that summarise them."""
