"""Long recordings: identify on a pose-diverse subset, refine on every frame, the motion in
chunks.
"""
