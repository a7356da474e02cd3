"""The variants that come with the package (cvtdesign/variants/), by name: each machine on the default basis
(`existing`: Kim's two-steering-roller CVT, `box`, `unequal`) and under Kim et al.'s contact law and fitted
constants (`<name>_kim`). A module of its own, without the physics, so that the command line's parser can name
them without importing the model."""
from __future__ import annotations

from importlib import resources
from pathlib import Path

SHIPPED = ("existing", "box", "unequal", "existing_kim", "box_kim", "unequal_kim")


def shipped_variant(name: str) -> Path:
    """The path of the shipped variant `name` (one of SHIPPED)."""
    return Path(str(resources.files("cvtdesign") / "variants" / f"{name}.yaml"))
