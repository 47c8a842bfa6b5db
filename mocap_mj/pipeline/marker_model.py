"""The model a marker set gives (:attr:`Recipe.marker_set <mocap_mj.pipeline.recipe.Recipe>`,
:attr:`Recipe.model`): its MJCF file, its landmarks and its markers' radius.

A set replaces the base model's marker sites (:func:`model_file`); one that the bundled
humanoid's own sites already are (Plug-in Gait or part of it) keeps the bundled model. With no
set named, the bundled set the labels fit is chosen (:func:`detected_set`), as
``mocap-mj identify`` chooses it.
"""

from __future__ import annotations

import hashlib
import tempfile
from collections.abc import Sequence
from pathlib import Path

from mocap_mj.capture.marker_set import load_marker_set, model_with_marker_set
from mocap_mj.capture.marker_sets import DEFAULT, detect, on_bundled_model, resolve
from mocap_mj.capture.subject import Subject

from ..io.atomic import atomic_write_text


def detected_set(labels: Sequence[str], renamed: set[str] | None = None) -> str:
    """The bundled set's name the ``labels`` fit (:func:`~mocap_mj.capture.marker_sets.detect`),
    else Plug-in Gait's."""
    return detect(list(labels), renamed=renamed or set()).chosen or DEFAULT


def set_path(name: str | None) -> Path | None:
    """The marker-set file of ``name`` (a bundled set's name or a YAML file; None: none)."""
    return None if name is None else resolve(name)


def model_file(marker_set: Path | None, base: str | None) -> str | None:
    """The MJCF file of the model: ``base`` (None: the bundled humanoid), its sites replaced
    by the markers of the set file ``marker_set`` when given. The model built from a set is
    written once, under the temporary folder, in a file named by a hash of the set and base
    model, so that ``ParameterSet`` can read it and a result can name it."""
    if marker_set is None:
        return base
    chosen = load_marker_set(marker_set)
    if base is None and on_bundled_model(chosen):
        return None  # Plug-in Gait or part of it: the bundled humanoid's own sites
    xml = model_with_marker_set(chosen, base).to_xml()
    digest = hashlib.sha256(xml.encode()).hexdigest()[:16]
    # "mocap-mj-models", not "mocap_mj": a folder named like the package in the temporary
    # folder would shadow it for any Python started there.
    folder = Path(tempfile.gettempdir()) / "mocap-mj-models"
    path = folder / f"model_{Path(marker_set).stem}_{digest}.xml"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, xml)
    return str(path)


def set_landmarks(
    marker_set: Path | None, base: str | None
) -> tuple[dict[str, str], dict[str, str]]:
    """The set's landmarks (marker -> landmark) and bodies (marker -> body); empty without a
    set, or for the bundled humanoid's own sites run as the default set."""
    if marker_set is None:
        return {}, {}
    chosen = load_marker_set(marker_set)
    if base is None and on_bundled_model(chosen):
        return {}, {}
    landmarks = {m.name: m.landmark for m in chosen.markers if m.landmark}
    return landmarks, {m.name: m.body for m in chosen.markers}


def with_set_radius(marker_set: Path | None, subject: Subject) -> Subject:
    """``subject`` with the marker diameter of the set (twice its ``marker_radius``) when the
    subject's measurements give none and the set's radius is not the default's (Plug-in
    Gait's 14 mm markers, which ``Subject.marker_radius`` assumes)."""
    if marker_set is None or subject.get("marker_diameter") is not None:
        return subject
    chosen = load_marker_set(marker_set)
    if chosen.marker_radius == subject.marker_radius:
        return subject
    out = subject.update(Subject())
    out.set("marker_diameter", 2 * chosen.marker_radius, f"marker set {marker_set.name}")
    return out
