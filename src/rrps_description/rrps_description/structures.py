"""The structures the robots climb (paper section 3), shipped by name: a pole (leaning or not),
a curved palm trunk (section 3.3), a structural frame's node (section 3.1, Figure 8) and a
facade, built from the structure models of :mod:`rrps_description.structure_models` (the route
every structure gives: grip frames, swings, forbidden intervals, mesh, clearance spheres).
Pure NumPy; no ROS import.
"""

from __future__ import annotations

import math

import numpy as np

from rrps_description.structure_models import BeamFrame, Facade, Structure, Tube, interpolate_frames

__all__ = [
    'Structure',
    'Tube',
    'BeamFrame',
    'Facade',
    'STRUCTURES',
    'pole',
    'palm_trunk',
    'structural_frame',
    'facade',
    'make_structure',
    'structure_from_parameters',
    'interpolate_frames',
]


# --- the shipped structures ---------------------------------------------------------------

def pole(length: float = 3.0, radius: float = 0.1, lean_deg: float = 0.0) -> Tube:
    """A straight pole (or pipe, cable) of constant radius, foot at the origin: vertical, or
    leaning ``lean_deg`` from the vertical about the world x axis (its top toward -y), so that
    its grip frames are the vertical pole's turned by that angle about x."""
    if not (length > 0.0 and radius > 0.0):
        raise ValueError('pole: length and radius must be > 0')
    if not (math.isfinite(lean_deg) and abs(lean_deg) < 90.0):
        raise ValueError(f'pole: lean_deg must be within (-90, 90), got {lean_deg}')
    lean = math.radians(lean_deg)
    z = np.linspace(0.0, length, 5)
    return Tube(np.c_[np.zeros(5), -math.sin(lean) * z, math.cos(lean) * z], np.full(5, radius), name='pole')


def palm_trunk(length: float = 3.0, radius: float = 0.15, radius_variation: float = 0.2,
               lean: float = 0.25) -> Tube:
    """A curved palm trunk (section 3.3): a 3-D centreline leaning ``lean`` [m] sideways over
    3 m with a gentle S in the other direction, radius ``radius * (1 ± radius_variation)``
    (a sine of 1.2 m wavelength: the trunk's swellings)."""
    if not (length > 0.0 and radius > 0.0 and 0.0 <= radius_variation < 1.0):
        raise ValueError('palm_trunk: length, radius > 0 and 0 <= radius_variation < 1')
    z = np.linspace(0.0, length, max(int(math.ceil(length / 0.2)), 4) + 1)
    x = lean * (1.0 - np.cos(np.pi * z / 3.0)) / 2.0
    y = 0.5 * lean * np.sin(2.0 * np.pi * z / 3.0) / 2.0
    r = radius * (1.0 + radius_variation * np.sin(2.0 * np.pi * z / 1.2))
    return Tube(np.c_[x, y, z], r, name='palm_trunk')


def structural_frame(column: float = 2.0, rafter: float = 2.0, bend_deg: float = 0.0,
                     junction_twist_deg: float = 90.0, node_clearance: float = 0.1,
                     out_of_plane: bool = False) -> BeamFrame:
    """A frame node the robot must pass (Figure 8): a column up to node ``J``, then a member
    leaving J (bent by ``bend_deg`` in the plane of the column's web, x-z, or with
    ``out_of_plane`` normal to it, y-z; straight on by default: a column splice) whose section is
    turned by ``junction_twist_deg`` about its axis, and two horizontal beams framing into J
    (drawn, not climbed): one in the bend's plane opposite the member, one normal to that plane.
    A gripper past J must grip turned by that angle; grippers keep ``node_clearance`` off J."""
    b = math.radians(bend_deg)
    bend = np.array([0.0, 1.0, 0.0]) if out_of_plane else np.array([1.0, 0.0, 0.0])
    across = np.array([1.0, 0.0, 0.0]) if out_of_plane else np.array([0.0, 1.0, 0.0])
    J = np.array([0.0, 0.0, column])
    nodes = {
        'base': (0.0, 0.0, 0.0),
        'J': tuple(J),
        'top': tuple(J + rafter * (math.sin(b) * bend + math.cos(b) * np.array([0.0, 0.0, 1.0]))),
        'east': tuple(J - 1.5 * bend),
        'north': tuple(J + 1.5 * across * (-1.0 if out_of_plane else 1.0)),
    }
    beams = [('base', 'J'), ('J', 'top'), ('J', 'east'), ('J', 'north')]
    return BeamFrame(nodes, beams, ['base', 'J', 'top'], junction_twist_deg=junction_twist_deg,
                     node_clearance=node_clearance)


def facade(length: float = 4.0) -> Facade:
    """A vertical building front in the world x-z plane, traversed horizontally along x."""
    return Facade(origin=(0.0, 0.0, 1.0), normal=(0.0, -1.0, 0.0), direction=(1.0, 0.0, 0.0),
                  length=length)


STRUCTURES = {'pole': pole, 'palm_trunk': palm_trunk, 'frame': structural_frame, 'facade': facade}


def make_structure(name: str, length: float | None = None, *, lean_deg: float = 0.0, junction_deg: float = 0.0,
                   out_of_plane: bool = False) -> Structure:
    """A shipped structure by name, at least ``length`` [m] long along its route; the pole
    leaning ``lean_deg`` (:func:`pole`); a frame's member leaves its node bent by ``junction_deg``
    (in the column's web plane, or normal to it with ``out_of_plane``; its section then not
    turned). The other structures stand as shipped."""
    if name not in STRUCTURES:
        raise ValueError(f'unknown structure {name!r}: one of {sorted(STRUCTURES)}')
    if name == 'pole':
        return pole(max(3.0, length or 0.0), lean_deg=lean_deg)
    if lean_deg:
        raise ValueError(f'lean_deg applies to the pole only, not to the {name}')
    if name == 'frame':
        if not 0.0 <= junction_deg <= 90.0:
            raise ValueError(f'junction_deg must be in 0 .. 90 deg, got {junction_deg!r}')
        bent = {} if junction_deg == 0.0 else {'bend_deg': junction_deg, 'junction_twist_deg': 0.0,
                                                'out_of_plane': out_of_plane}
        rafter = 2.0 if length is None or length <= 4.0 else length - 2.0
        return structural_frame(column=2.0, rafter=rafter, **bent)
    if name == 'palm_trunk':
        return palm_trunk(max(3.0, length or 0.0))
    return STRUCTURES[name](max(4.0, length or 0.0))


def structure_from_parameters(values) -> Structure:
    """The structure that a node's parameters ``values`` describe: ``structure`` (a name),
    ``structure_length`` (0: the shipped length), ``structure_lean_deg``, ``junction_deg`` and
    ``out_of_plane`` (those the node declares; :func:`make_structure`)."""
    return make_structure(values['structure'], values.get('structure_length') or None,
                          lean_deg=values.get('structure_lean_deg', 0.0), junction_deg=values.get('junction_deg', 0.0),
                          out_of_plane=values.get('out_of_plane', False))
