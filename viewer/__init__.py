"""mocap_viewer: interactive playback and offscreen rendering of mocap-mj results."""
