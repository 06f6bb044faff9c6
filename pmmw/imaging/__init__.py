"""From traced radiance to the sensor image: PSF, noise, display scaling."""
