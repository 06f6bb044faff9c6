"""Writers and readers: atomic files, OpenEXR images, PNG previews and the run report."""
