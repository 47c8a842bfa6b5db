"""What the commands write: an identification's result folder and report, the Plug-in Gait
folder, the score against a synthetic truth.
"""
