"""Length units as marker files state them, and their size in metres."""

from __future__ import annotations

_METRES_PER_UNIT = {
    "mm": 1e-3, "millimeter": 1e-3, "millimeters": 1e-3, "millimetre": 1e-3, "millimetres": 1e-3,
    "cm": 1e-2, "centimeter": 1e-2, "centimeters": 1e-2, "centimetre": 1e-2, "centimetres": 1e-2,
    "m": 1.0, "meter": 1.0, "meters": 1.0, "metre": 1.0, "metres": 1.0,
}  # fmt: skip


def metres_per_unit(unit: str) -> float | None:
    """Metres in one ``unit`` (case-insensitive: mm, cm, m and their spelt-out names), or None."""
    return _METRES_PER_UNIT.get(unit.strip().lower())
