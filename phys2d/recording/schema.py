"""The format of a phys2d recording, in one place: timelines, entity paths, fields, units, dtypes.

The recorder writes what this module names and ``playback`` reads it back by the
same names; neither spells an entity path or a field name of its own.

Precision. A value that is read back and compared (a body's pose and velocity, the
residual of every sweep, the energies, the plotted per-contact series) is stored as
float64, bit for bit what the engine held. A value that is drawn or looked at in the
viewer is stored as float32: the per-tick contact table (lambda_n, lambda_t,
separation), the contact points and normals (as the arrows' origins and directions)
and the outlines. Drawn positions are also rounded to ``DRAW_GRID`` (1/16384 m,
61 um, far below a pixel) and unit normals to ``NORMAL_GRID``, so that a body or a
contact at rest writes the same bytes tick after tick and the file compresses.

Layout of one run (``<run>`` is ``runs/<label>/`` when several runs share a file,
empty otherwise). Timelines: ``tick`` (sequence, ``w.tick``), ``sim_time``
(duration, ``w.time``); the residuals also carry ``sweep``, the running count of
solver sweeps, on which they read as one continuous curve.

    <run>world                   AnnotationContext: class ids -> names and colours (static)
    <run>world/sim               the y-flip (physics is y-up, a 2D view is y-down) (static)
    <run>world/sim/bodies        every dynamic body, one LineStrips2D per body (a polygon's closed
                                 outline; a circle's rim, drawn from its centre along its angle),
                                 and the table BODY_FIELDS (float64), every tick; its class ids
                                 (sleeping bodies dimmed) on the ticks where they change
    <run>world/sim/static        the same for static bodies, written when they change (latest-at)
    <run>world/sim/contacts      Arrows2D from each contact point along its normal (NORMAL_LENGTH),
                                 coloured by class (warm-started or new), and CONTACT_FIELDS
    <run>world/sim/joints        LineStrips2D anchor to anchor, when the world has joints
    <run>contacts/lambda/<name>  Scalars [lambda_n, lambda_t] (N s), float64, for the plotted contacts
    <run>contacts/penetration/<name>  Scalars -separation (mm), float64, for the same contacts
    <run>joints/reaction/j<k>/r<row>  the impulse of each joint row (N s)
    <run>solver/residual         Scalars log10 of the residual (for the plot), one row per sweep
    <run>solver/sweeps           the field ``residual`` (m/s, float64), one row per sweep: apart from
                                 the plotted entity, as Rerun (0.30 on) plots every numeric component
                                 of an entity in a time series view (it drew this as a flat line at 0)
    <run>stats/<name>            STATS: energies, momenta, deepest overlap, counts, one row per tick
    <run>replay/state            STATE_HASH (uint64, ``World.state_hash``) and DT (float64, s: the step
                                 that led to the tick, 0 before the first), one row per tick
    <run>replay/keyframes        KEYFRAME: the world's snapshot (``phys2d.snapshot``), zlib-compressed,
                                 on the run's first tick and every ``keyframe_every`` ticks
    <run>replay/responder        RESPONDER_SPEC: the responder's class and settings as JSON
                                 (``snapshot.responder_spec``), on the ticks where they changed

A contact's ``<name>`` is ``b<uid_a>-b<uid_b>/f<feature>`` (``contact_entity``): the
bodies' uids and the manifold's feature id, the contact's identity across ticks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# -- timelines ---------------------------------------------------------------------------
TICK = "tick"  # sequence: w.tick
SIM_TIME = "sim_time"  # duration: w.time, s (Rerun keeps whole nanoseconds)
SWEEP = "sweep"  # sequence: running count of solver sweeps (residual rows only)

# -- entity paths, relative to a run's prefix ------------------------------------------------
WORLD = "world"
SIM = "world/sim"
BODIES = "world/sim/bodies"
STATIC = "world/sim/static"
CONTACTS = "world/sim/contacts"
JOINTS = "world/sim/joints"
LAMBDA = "contacts/lambda"
PENETRATION = "contacts/penetration"
REACTION = "joints/reaction"
RESIDUAL = "solver/residual"
SWEEPS = "solver/sweeps"  # the exact residual per sweep, not plotted
STATS_ROOT = "stats"
REPLAY_STATE = "replay/state"
REPLAY_KEYFRAMES = "replay/keyframes"
REPLAY_RESPONDER = "replay/responder"
RUNS_ROOT = "runs"
PROPERTIES_ENGINE = "phys2d"  # recording property: engine version, scene, name
PROPERTIES_RUN = "run"  # recording property of an unnamed run; named runs use runs/<label>


def run_prefix(label: str | None) -> str:
    """The entity prefix of a run: '' for a file's single unnamed run, else ``runs/<label>/``."""
    return "" if not label else f"{RUNS_ROOT}/{label}/"


def run_property(label: str | None) -> str:
    """The recording-property name holding what a run was (responder, scene, ...)."""
    return PROPERTIES_RUN if not label else f"{RUNS_ROOT}/{label}"


# -- fields --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Field:
    """One column of a table: its name in the file, unit and numpy dtype."""

    name: str
    unit: str
    dtype: type
    doc: str


BODY_FIELDS = (
    Field("uid", "", np.int64, "the body's uid (w.body_uids)"),
    Field("x", "m", np.float64, "centre of mass, x"),
    Field("y", "m", np.float64, "centre of mass, y"),
    Field("angle", "rad", np.float64, "theta"),
    Field("vx", "m/s", np.float64, "velocity, x"),
    Field("vy", "m/s", np.float64, "velocity, y"),
    Field("omega", "rad/s", np.float64, "angular velocity"),
)
CONTACT_FIELDS = (
    Field("body_a", "", np.uint32, "uid of body a (the normal points from a to b)"),
    Field("body_b", "", np.uint32, "uid of body b"),
    Field("feature", "", np.uint16, "feature id: which edges or vertices touch"),
    Field("lambda_n", "N s", np.float32, "normal impulse of the step"),
    Field("lambda_t", "N s", np.float32, "friction impulse along t = (-n_y, n_x)"),
    Field("separation", "m", np.float32, "C: negative while the shapes overlap"),
    Field("warm_started", "", np.bool_, "the contact cache supplied last tick's impulses"),
)
RESIDUAL_FIELD = Field("residual", "m/s", np.float64, "largest velocity correction of the sweep")
STATE_HASH = Field("state_hash", "", np.uint64, "World.state_hash() at the tick")
DT = Field("dt", "s", np.float64, "the step that led to the tick (0 before the first)")
KEYFRAME = Field("snapshot_zlib", "", np.uint8, "World.snapshot() at the tick, zlib-compressed")
RESPONDER_SPEC = Field("spec", "", np.str_, "the responder's class and settings, JSON")


@dataclass(frozen=True)
class Stat:
    """A per-tick aggregate: ``stats/<name>``, one float64 scalar per tick."""

    name: str
    unit: str
    label: str  # legend name


STATS = (
    Stat("energy/kinetic", "J", "kinetic"),
    Stat("energy/potential", "J", "potential"),
    Stat("energy/total", "J", "total"),
    Stat("momentum/x", "kg m/s", "p_x"),
    Stat("momentum/y", "kg m/s", "p_y"),
    Stat("angular_momentum", "kg m^2/s", "L"),
    Stat("max_penetration", "mm", "deepest overlap"),
    Stat("contact_count", "", "contacts"),
    Stat("cache_hit_rate", "", "cache hit rate"),
    Stat("iterations", "", "sweeps, passes or sub-steps"),
)
STAT_NAMES = tuple(s.name for s in STATS)

# -- units of the plotted series -----------------------------------------------------------
LAMBDA_UNIT = "N s"
PENETRATION_UNIT = "mm"
PENETRATION_SCALE = 1e3  # mm per m: plotted penetration = -separation * PENETRATION_SCALE
RESIDUAL_FLOOR = 1e-16  # m/s: a residual of 0 is plotted as log10 of this

# -- drawing ----------------------------------------------------------------------------------
DRAW_GRID = 2.0**-14  # m: drawn positions are rounded to this (61 um)
NORMAL_GRID = 2.0**-16  # unit normals are rounded to this before drawing
NORMAL_LENGTH = 0.25  # m, drawn length of a contact normal (a power of two: vectors / length is exact)
CIRCLE_SEGMENTS = 24  # a circle's rim is drawn as this many segments
LINE_RADIUS = 0.02  # m, half width of outlines
ARROW_RADIUS = 0.012  # m

CLASS_BODY, CLASS_CIRCLE, CLASS_STATIC, CLASS_WARM, CLASS_COLD, CLASS_JOINT = 1, 2, 3, 4, 5, 6
CLASS_ASLEEP_BODY, CLASS_ASLEEP_CIRCLE = 7, 8  # a sleeping body: its class's colour, dimmed
ANNOTATIONS = (
    (CLASS_BODY, "body", (80, 140, 255)),
    (CLASS_CIRCLE, "circle", (255, 160, 40)),
    (CLASS_STATIC, "static", (150, 150, 150)),
    (CLASS_WARM, "warm-started contact", (40, 190, 80)),
    (CLASS_COLD, "new contact", (230, 40, 40)),
    (CLASS_JOINT, "joint", (200, 80, 220)),
    (CLASS_ASLEEP_BODY, "body, asleep", (40, 70, 128)),
    (CLASS_ASLEEP_CIRCLE, "circle, asleep", (128, 80, 20)),
)

# distinct colours for plotted series (contacts, runs): Tableau 10, without its greys
PALETTE = (
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (188, 189, 34),
    (23, 190, 207),
)
ENERGY_COLOURS = {"kinetic": (214, 39, 40), "potential": (31, 119, 180), "total": (60, 60, 60)}
ENERGY_HIDDEN = ("energy/potential", "energy/total")  # off until clicked in the legend: they dwarf the kinetic


def lighter(colour: tuple[int, int, int], amount: float = 0.5) -> tuple[int, int, int]:
    """``colour`` mixed with white (amount 0: unchanged, 1: white)."""
    r, g, b = colour
    return (round(r + (255 - r) * amount), round(g + (255 - g) * amount), round(b + (255 - b) * amount))


# -- contact identities ------------------------------------------------------------------
UID_BITS = 23
FEATURE_BITS = 16
_UID_MASK = (1 << UID_BITS) - 1
_FEATURE_MASK = (1 << FEATURE_BITS) - 1


def contact_key(uid_a, uid_b, feature):
    """The engine's contact key (``uid_a << 39 | uid_b << 16 | feature``), scalars or arrays."""
    return (np.asarray(uid_a, np.int64) << 39) | (np.asarray(uid_b, np.int64) << 16) | np.asarray(feature, np.int64)


def split_key(key):
    """(uid_a, uid_b, feature) of contact keys, scalars or arrays."""
    key = np.asarray(key, np.int64)
    return key >> 39, (key >> 16) & _UID_MASK, key & _FEATURE_MASK


def contact_entity(key: int) -> str:
    """The entity name of a contact identity: ``b<uid_a>-b<uid_b>/f<feature>``."""
    a, b, f = (int(v) for v in split_key(int(key)))
    return f"b{a}-b{b}/f{f}"


def contact_label(key: int) -> str:
    """A contact's name in a plot legend: its bodies and its feature id."""
    a, b, f = (int(v) for v in split_key(int(key)))
    return f"b{a}-b{b} f{f}"


def parse_contact(name: str) -> int:
    """The key of a contact named ``b<a>-b<b>/f<feature>`` (or ``... f<feature>``)."""
    if not isinstance(name, str):
        raise TypeError(f"contact must be a name like 'b3-b7/f512', got {type(name).__name__}")
    text = name.strip().replace(" ", "/")
    try:
        bodies, feature = text.split("/")
        a, b = bodies.split("-")
        if not (a.startswith("b") and b.startswith("b") and feature.startswith("f")):
            raise ValueError
        ua, ub, f = int(a[1:]), int(b[1:]), int(feature[1:])
    except ValueError:
        raise ValueError(f"contact must be a name like 'b3-b7/f512' (bodies' uids, feature id), got {name!r}") from None
    if not (0 <= ua < ub <= _UID_MASK and 0 <= f <= _FEATURE_MASK):
        raise ValueError(f"contact {name!r}: need uids 0 <= a < b < 2^23 and a feature id < 2^16")
    return int(contact_key(ua, ub, f))


def joint_entity(joint: int, row: int) -> str:
    """The entity name of a joint row: ``j<k>/r<row>``."""
    return f"j{int(joint)}/r{int(row)}"
