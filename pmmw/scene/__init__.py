"""The scene: geometry, materials, imager pose and rays, sky."""
