"""Human-body knowledge: anatomical priors and ranges, regressions of Plug-in Gait, the initial
model, soft-tissue sliding, plausibility checks, the segment table.
"""
