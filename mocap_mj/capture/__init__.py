"""What a recording holds beyond coordinates: the marker set it follows, the landmarks its
markers name, the subject's measurements, and the checks and quality findings of its markers.
"""
