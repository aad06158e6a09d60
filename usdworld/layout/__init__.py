"""From image objects and a camera to metric placements: priors, depth, yaw, collisions, surfaces."""
