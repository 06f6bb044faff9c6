"""Physical optics (`pmmw po`): radar cross sections of meshes at millimetre waves (Xia et al. 2023)."""
