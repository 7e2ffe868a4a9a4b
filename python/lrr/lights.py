"""Lights that move (lrr_light_source, include/lrr.h "lights"), for Operator.direct_light.

Units follow the scene's emission. Each light is a small dataclass; a dict with "kind"
("point", "spot", "area", "sun") and the same field names works too:

    Point(position, rgb)       radiant intensity rgb per steradian: H = rgb·max(0, n·ω)/r²
    Spot(position, direction, rgb, cone_angle, cone_softness=0)
                               a point light times a smoothstep cone (angles in radians)
    Area(position, u, v, rgb, samples=16)
                               a one-sided rectangle (centre, edges u and v) of radiosity rgb,
                               emitting on the side of u × v
    Sun(direction, rgb)        at infinity towards direction; irradiance rgb facing it

Lights cast no shadow themselves and receive no light; the scene's triangles shadow them.
"""
import ctypes
from dataclasses import dataclass, field, fields
from typing import Sequence

from . import _ffi

KINDS = {"point": 1, "spot": 2, "area": 3, "sun": 4}


@dataclass
class Point:
    position: Sequence[float]
    rgb: Sequence[float]
    kind: str = field(default="point", init=False)


@dataclass
class Spot:
    position: Sequence[float]
    direction: Sequence[float]
    rgb: Sequence[float]
    cone_angle: float
    cone_softness: float = 0.0
    kind: str = field(default="spot", init=False)


@dataclass
class Area:
    position: Sequence[float]
    u: Sequence[float]
    v: Sequence[float]
    rgb: Sequence[float]
    samples: int = 16
    kind: str = field(default="area", init=False)


@dataclass
class Sun:
    direction: Sequence[float]
    rgb: Sequence[float]
    kind: str = field(default="sun", init=False)


def _fields(light):
    if isinstance(light, dict):
        return dict(light)
    return {f.name: getattr(light, f.name) for f in fields(light)}


def to_c(lights):
    """A ctypes array of lrr_light_source for a sequence of lights (or one light). Values
    are copied as given: lrr checks them and names the light and the field."""
    if isinstance(lights, dict) or not isinstance(lights, (list, tuple)):
        lights = [lights]
    arr = (_ffi.LightSource * len(lights))()
    for i, light in enumerate(lights):
        f = _fields(light)
        kind = f.pop("kind", None)
        c = arr[i]
        c.kind = KINDS.get(kind, 0) if isinstance(kind, str) else int(kind or 0)
        if c.kind == 0:
            # lrr names an unknown kind itself; keep the value it will see recognisable
            c.kind = -1
        for name, value in f.items():
            if name not in ("position", "direction", "u", "v", "rgb", "cone_angle",
                            "cone_softness", "samples"):
                raise TypeError("light %d: unknown field '%s'" % (i, name))
            if name in ("cone_angle", "cone_softness"):
                setattr(c, name, float(value))
            elif name == "samples":
                setattr(c, name, int(value))
            else:
                v = [float(x) for x in value]
                if len(v) != 3:
                    raise ValueError("light %d: %s has %d values, expected 3" % (i, name, len(v)))
                setattr(c, name, (ctypes.c_float * 3)(*v))
    return arr
