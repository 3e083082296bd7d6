"""3D terrains shared by the particle simulators: voxel densities of particles and the surface
meshes of voxel grids (marching cubes, smoothing, enclosed volume). Nothing here imports the
simulators; they and the jobs import it."""
