"""Camera model, homography (normalised DLT) and ground projection: pure numpy, no I/O."""
