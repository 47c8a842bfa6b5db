"""Identification of theta (segment lengths and marker offsets) with the motion."""

from __future__ import annotations

from .lm import LMResult, LMSettings, Termination, TrialData, identify_lm

__all__ = ["LMResult", "LMSettings", "Termination", "TrialData", "identify_lm"]
