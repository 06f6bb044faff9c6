"""Physical constants, SI (CODATA 2018): the one place pmmw defines them."""

C0 = 299_792_458.0  # speed of light in vacuum [m/s] (exact)
EPS0 = 8.8541878128e-12  # vacuum permittivity [F/m]
