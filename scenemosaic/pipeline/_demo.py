"""The bundled demo scene: a bedroom-study built from procedural furniture.

Its poses are deliberately imprecise, the way a learned layout prior or an image-to-3D
reconstruction leaves them (objects a few centimetres sunk or floating, a chair driven into
the desk, a lamp hanging low), so that every pipeline stage has real work to do.
"""

from __future__ import annotations

import math

from scenemosaic.scene import AssetRef, Pose, Provenance, Room, Scene, SceneObject

__all__ = ["demo_scene"]

# id, category, extents (w, d, h), position (x, y, z of the bottom centre), yaw (rad), description
_OBJECTS: list[tuple[str, str, tuple[float, float, float], tuple[float, float, float], float, str]] = [
    ("bed", "double_bed", (1.6, 2.1, 1.0), (1.6, 2.93, 0.0), 0.0, "double bed, headboard against the wall"),
    ("nightstand_left", "nightstand", (0.45, 0.4, 0.55), (0.5, 3.76, 0.02), 0.0, "nightstand left of the bed"),
    ("nightstand_right", "nightstand", (0.45, 0.4, 0.55), (2.7, 3.78, -0.03), 0.0, "nightstand right of the bed"),
    ("table_lamp", "table_lamp", (0.28, 0.28, 0.45), (0.5, 3.76, 0.6), 0.0, "small lamp on the left nightstand"),
    ("wardrobe", "wardrobe", (1.2, 0.6, 2.1), (4.17, 3.2, 0.0), -math.pi / 2, "two-door wardrobe"),
    ("desk", "desk", (1.2, 0.6, 0.75), (1.2, 0.33, 0.0), math.pi, "work desk against the wall"),
    ("chair", "office_chair", (0.55, 0.55, 0.95), (1.25, 0.85, 0.04), 0.05, "office chair at the desk"),
    ("laptop", "laptop", (0.34, 0.24, 0.03), (1.0, 0.36, 0.77), math.pi, "open laptop on the desk"),
    ("mug", "mug", (0.09, 0.09, 0.1), (1.55, 0.3, 0.74), 0.3, "coffee mug on the desk"),
    ("book", "book", (0.17, 0.24, 0.04), (1.7, 0.45, 0.8), 0.2, "book lying on the desk"),
    ("bookshelf", "bookshelf", (0.8, 0.35, 1.8), (0.2, 1.6, 0.0), math.pi / 2, "tall open bookshelf"),
    ("vase", "vase", (0.15, 0.15, 0.3), (0.2, 1.5, 1.83), 0.0, "vase on top of the bookshelf"),
    ("rug", "rug", (1.6, 1.2, 0.01), (2.6, 1.9, 0.0), 0.0, "rectangular rug"),
    ("pendant_lamp", "pendant_lamp", (0.5, 0.5, 0.6), (2.4, 2.0, 2.05), 0.0, "pendant lamp hanging over the rug"),
    ("plant", "plant", (0.4, 0.4, 0.9), (4.15, 0.38, 0.0), 0.0, "potted plant in the corner"),
    ("tv", "tv", (1.0, 0.08, 0.6), (3.2, 0.06, 1.0), math.pi, "flat TV mounted on the wall"),
]


def demo_scene() -> Scene:
    """A 4.5 x 4.0 m bedroom-study with 16 procedural objects and imprecise poses."""
    objects = [
        SceneObject(
            id=oid,
            category=category,
            description=description,
            asset=AssetRef(kind="procedural", category=category, extents=extents),
            pose=Pose.from_yaw(position, yaw),
        )
        for oid, category, extents, position, yaw, description in _OBJECTS
    ]
    return Scene(
        id="demo_bedroom_study",
        room=Room.rectangle(0.0, 0.0, 4.5, 4.0, ceiling_height=2.7),
        objects=objects,
        metadata={"description": "bundled demo: a bedroom with a work corner"},
        provenance=Provenance(source_format="native", importer="scenemosaic.demo"),
    )
