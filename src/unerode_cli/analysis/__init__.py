"""Analysis of terrains and runs: river profiles, terrace comparison, incision rates,
hypsometry and differences between DEMs. Pure functions on arrays (no file I/O)."""
