"""mocap_viewer: interactive playback and offscreen rendering of mocap-mj results.

Modules: ``playback`` (what is shown: poses, markers, residuals, ghost model, frame selection),
``scene`` (markers and residuals as primitives and MuJoCo user geoms), ``render`` (MuJoCo and
pyrender offscreen renderers), ``output`` (PNG / MP4 / GIF files), ``meshes`` (trimesh meshes
of geoms), ``glb`` (GLB export), ``interactive`` (MuJoCo's passive viewer) and ``cli`` (the
``view``, ``render`` and ``export`` subcommands). See docs/viewer.md.

This package imports :mod:`mocap_mj`; the library never imports it.
"""
