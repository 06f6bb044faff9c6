"""Physical constants, SI (CODATA 2018): the one place pmmw defines them."""

C0 = 299_792_458.0  # speed of light in vacuum [m/s] (exact)
EPS0 = 8.8541878128e-12  # vacuum permittivity [F/m]

# A triangle is degenerate when |e1 x e2| <= DEGENERATE_REL x (longest edge)^2: below it the float64
# cross product is rounding noise and the face has no usable plane (`pmmw.trace.intersect`
# gives it a zero normal and never hits it; `pmmw.scene.geometry` drops it on load).
DEGENERATE_REL = 1e-12
