"""Atmosphere: ITU-R gas, cloud/fog and rain attenuation on layered reference profiles.

`model` builds an `AtmosphereModel` per (atmosphere, frequency): the sky's brightness temperature
by elevation and the attenuation and emission of every straight path through the scene's air.
`itu` holds the vectorized ITU-R equations it is made of.
"""

from pmmw.atmosphere.model import (
    PROFILES,
    T_CMB,
    Atmosphere,
    AtmosphereModel,
    AtmosphereLayer,
)

__all__ = ["PROFILES", "T_CMB", "Atmosphere", "AtmosphereModel", "AtmosphereLayer"]
