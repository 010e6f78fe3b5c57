//! penumbra-spheres: variational bounding sphere sets (SHEXP §6.2–6.3). Work in progress (issue 3).
