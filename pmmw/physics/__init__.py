"""Wave physics of pmmw: interface and coating coefficients (`fresnel`, `multilayer`), polarization
bookkeeping (`jones`). Conventions: docs/ARCHITECTURE.md and docs/PHYSICS.md."""
