"""Sandstone (002, Yang et al. 2025, Arenite): a 3D rock of particles eroded by wind and water,
weakened where it loses section and hardened where its stress passes the interlocking threshold."""
