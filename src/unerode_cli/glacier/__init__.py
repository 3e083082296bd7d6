"""Glaciers (001 §3–7): mass balance, ice flow (Blatter–Pattyn and SIA), ice transport,
glacial erosion, and the glacial cycles that couple them with the other processes.

Modules, one job each:

- ``massbalance``: M = min(p_max, β(s − E)) (001 Eq. 2);
- ``lattice``: the terrain-following lattice of N layers (001 §4.2) and its degrees of freedom;
- ``blatter``: horizontal ice velocities minimising the Blatter–Pattyn energy (001 Eq. 7),
  with the numba energy and analytic gradient in ``blatter_energy``, the column preconditioner in
  ``blatter_preconditioner``, the L-BFGS passes in ``lbfgs_kernels`` and the multigrid transfers
  in ``multigrid_transfers``;
- ``sia``: the shallow-ice approximation, the fast baseline;
- ``transport``: ∂H/∂t = M − ∇·(H ū) (001 Eq. 1), limited upwind fluxes in ``transport_kernels``;
- ``multiscale``: long steps of that transport, δt(x) and a Gaussian stack of T (001 §5);
- ``erosion``: abrasion and quarrying from the sliding velocity (001 §6.1).
- ``coupled``: the coupled time stepping of all of them (001 §3.2);
- ``cycle``: the processes of ice-free ground after each glacier step (001 §6: hill slope, debris
  flow, rivers where the ice is thinner than 3 m) and uplift;
- ``lakes``: water in the depressions of the bed that ice does not fill (001 §7).

Conventions: x along columns (east), y along rows (increasing row index, i.e. south on a
north-up raster); velocity components (u, v) follow the same axes. Lengths in metres, time in
years, velocities in m/y (= m/a), stresses in Pa. Importing this package does not load numba.
"""
