"""What every responder follows, and the report a step leaves behind.

A responder turns the constraint rows of a step into impulses: it changes the
velocities V in place, and may move positions itself (push-apart, split push,
sub-steps, the restitution pass after the move). The world builds the rows with
the responder's own Baumgarte factor, slop, push cap, bounce threshold and friction
model, fills ``ctx.rows.lam`` with the cached impulses when the responder asks for warm
starting, calls ``respond`` and reads the impulses back from ``ctx.rows.lam``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constraints.order import COLOUR_ORDER, PAIR_ORDER, PART_ORDER
from ..constraints.rows import FRICTION_COULOMB, Rows


@dataclass(eq=False)
class StepContext:
    """What a responder sees of one step (arrays are the world's own: edit in place)."""

    dt: float  # s
    x: np.ndarray  # (N, 2) centres of mass, m
    theta: np.ndarray  # (N,) angles, rad
    V: np.ndarray  # (N, 3) [vx, vy, omega] after external forces
    V1: np.ndarray  # (N, 3) the velocities the tick began with, before external forces
    M_inv: np.ndarray  # (N, 3) diagonal of M^-1
    rows: Rows  # the rows and the row map: rows.normal_row[q], rows.friction_row[q] are contact q's below
    n_contacts: int  # K; the contact arrays below are in row (solve) order, joint rows follow the contacts
    # (in contact order for a responder whose contacts_in_row_order is False: rows.order[q] is row pair q's)
    body_a: np.ndarray  # (K,) contact bodies (for responders that work pair by pair)
    body_b: np.ndarray
    point: np.ndarray  # (K, 2) contact points p, m
    normal: np.ndarray  # (K, 2) from a to b
    separation: np.ndarray  # (K,) m, negative when overlapping
    restitution: np.ndarray  # (K,) mixed e of each contact
    gravity: np.ndarray | None = None  # (2,) m/s^2, the only external force
    joints: object = None  # the world's packed joints (``JointArrays``), for responders that rebuild joint rows
    anchor: np.ndarray | None = None  # (K, 4) lever arms r_a, r_b (m) as each manifold was found
    forces: np.ndarray | None = None  # (N, 3) F_ext when bodies have more than m g on them (below)
    threads: int = 1  # the cores the step may use (``World.threads``), for responders that split their work
    part: np.ndarray | None = None  # (N,) each body's part of the solve order (``constraints.order.partition``)

    @property
    def F_ext(self) -> np.ndarray:
        """(N, 3) external forces and torques [f_x, f_y, tau] (N, N m) on the dynamic bodies: m g,
        or, where a body has a gravity_scale, an applied force or damping, the force that took
        V1 to V over dt (so V = V1 + dt M^-1 F_ext holds, damping included)."""
        if self.forces is not None:
            return self.forces
        F = np.zeros(self.M_inv.shape)
        if self.gravity is not None:
            dyn = self.M_inv[:, 0] > 0.0
            F[dyn, :2] = self.gravity / self.M_inv[dyn, 0:1]
        return F


@dataclass(eq=False)
class SolveResult:
    """What ``Responder.respond`` returns: the work done and each unit's residual. Checked when
    built, so a wrong value is named where it is made, not at the step that reads it."""

    iterations: int  # the sweeps, passes or sub-steps made (>= 0), counted in ``Responder.counts``
    residuals: np.ndarray  # (iterations,) largest velocity correction of each sweep, m/s (finite, kept as float64)
    system: object = None  # the assembled matrix system, for responders that build one
    integrated: bool = False  # True if the responder moved the positions itself (sub-steps, or a pass after)

    def __post_init__(self) -> None:
        if isinstance(self.iterations, (bool, np.bool_)) or not isinstance(self.iterations, (int, np.integer)):
            raise TypeError(f"SolveResult: iterations must be an integer, got {self.iterations!r}")
        if self.iterations < 0:
            raise ValueError(f"SolveResult: iterations must be >= 0, got {self.iterations}")
        self.iterations = int(self.iterations)
        r = self.residuals
        if r is None or isinstance(r, (str, bytes)):
            raise TypeError(f"SolveResult: residuals must be a sequence of numbers (m/s), got {r!r}")
        try:
            a = np.asarray(r)
        except Exception as exc:  # ragged input and the like
            raise TypeError(f"SolveResult: residuals must be a sequence of numbers (m/s): {exc}") from None
        if a.dtype == object or a.dtype.kind not in "iuf" or a.ndim != 1:
            raise TypeError(f"SolveResult: residuals must be a 1-D sequence of numbers (m/s), got {r!r}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"SolveResult: residuals must be finite, got {a.tolist()[:8]}")
        self.residuals = a.astype(np.float64)
        if not isinstance(self.integrated, (bool, np.bool_)):
            raise TypeError(f"SolveResult: integrated must be True or False, got {self.integrated!r}")
        self.integrated = bool(self.integrated)


def check_joints_supported(responder: Responder, joints: bool, mice: bool) -> None:
    """Refuse a responder that cannot solve the joints of a world with ``joints`` (and mouse joints,
    ``mice``): ValueError saying which responders can."""
    if joints and not responder.handles_joints:
        raise ValueError(
            f"responder {responder.name!r} cannot solve joints: it handles contact pairs only "
            "(as the lecture's naive takes do); use phys2d.PGS() or phys2d.SoftStep() in a world with joints"
        )
    if mice and not responder.solves_mouse_joints:
        raise ValueError(
            f"responder {responder.name!r} cannot solve mouse joints: their soft pull has a solve of its own "
            "(phys2d.responders.mouse); use phys2d.PGS() or phys2d.SoftStep()"
        )


EMPTY = np.zeros(0)
EMPTY.flags.writeable = False  # a read-only empty array, shared by every report that has nothing to show


class StepReport:
    """What the last ``World.step`` did (``w.last_step``).

    responder        the responder's name
    dt               the step, s
    count            the work the responder did, counted in ``counted``: PGS sweeps,
                     IterativeImpulse passes, SoftStep sub-steps (``Responder.counts``)
    counted          which: 'sweeps', 'passes', 'substeps' (or 'iterations' for others)
    iterations       ``count`` under its older name, whatever was counted
    residuals        residuals[s] is the largest velocity correction |delta lambda_k| A_kk
                     (m/s) any row needed in sweep (pass, sub-step) s: it falls towards 0
                     as the iterations converge
    max_penetration  m, the deepest overlap at collision time
    contact_count, cache_hits   contacts of the step, and how many the cache warm started
    joint_impulses   lambda of the joint rows, in joint order (N s)
    system           the assembled matrix system, for responders that build one
    solve_order      the q-th contact visited (and given the q-th pair of rows of the
                     step's system) is solve_order[q]

    Its arrays are read-only: the report describes a step taken. The world may lend it its
    buffers of residuals and solve order (``lent=True``: their first ``count`` and
    ``contact_count`` entries are the report's): they are copied out when first read, or by
    the world before a step writes those buffers again (``own``), so a step that nobody asks
    about copies nothing.
    """

    __slots__ = (
        "responder",
        "dt",
        "count",
        "counted",
        "_residuals",
        "max_penetration",
        "contact_count",
        "cache_hits",
        "_joint_impulses",
        "system",
        "_solve_order",
        "_sealed",
        "_lent",
        "__weakref__",
    )

    def __init__(
        self,
        responder: str = "none",
        dt: float = 0.0,
        iterations: int = 0,
        residuals: np.ndarray = EMPTY,
        max_penetration: float = 0.0,
        contact_count: int = 0,
        cache_hits: int = 0,
        joint_impulses: np.ndarray = EMPTY,
        system: object = None,
        solve_order: np.ndarray = EMPTY,
        counted: str = "iterations",
        lent: bool = False,
    ) -> None:
        self.responder = responder
        self.dt = dt
        self.count = iterations
        self.counted = counted
        self._residuals = residuals
        self.max_penetration = max_penetration
        self.contact_count = contact_count
        self.cache_hits = cache_hits
        self._joint_impulses = joint_impulses
        self.system = system
        self._solve_order = solve_order
        self._sealed = False
        self._lent = lent

    def own(self) -> None:
        """Copy the residuals and solve_order lent from the world's buffers (the world calls it
        before a step writes them again, if the report is still held)."""
        if self._lent:
            self._residuals = self._residuals[: self.count].copy()
            self._solve_order = self._solve_order[: self.contact_count].copy()
            self._lent = False

    def read_only(self) -> StepReport:
        """Make the report's arrays (and its system's) read-only, and return self."""
        if not self._sealed:
            self.own()
            for a in (self._residuals, self._joint_impulses, self._solve_order):
                a.flags.writeable = False
            if self.system is not None:
                self.system.read_only()  # type: ignore[attr-defined]
            self._sealed = True
        return self

    @property
    def residuals(self) -> np.ndarray:
        """(count,) m/s, read-only."""
        return self.read_only()._residuals

    @property
    def joint_impulses(self) -> np.ndarray:
        """Joint rows' lambda (N s), read-only."""
        return self.read_only()._joint_impulses

    @property
    def solve_order(self) -> np.ndarray:
        """(K,) contact indices in the order visited, read-only."""
        return self.read_only()._solve_order

    @property
    def iterations(self) -> int:
        """``count``: the sweeps, passes or sub-steps of the step (see ``counted``)."""
        return self.count

    @property
    def cache_hit_rate(self) -> float:
        """Fraction of this step's contacts found in the cache (1.0 when there were none)."""
        return self.cache_hits / self.contact_count if self.contact_count else 1.0

    def __repr__(self) -> str:
        residuals = self.residuals
        res = f"{residuals[-1]:.3g} m/s" if residuals.size else "-"
        return (
            f"<StepReport {self.responder}: {self.contact_count} contacts, "
            f"{self.cache_hits} cached, {self.count} {self.counted}, final residual {res}, "
            f"max penetration {self.max_penetration:.4g} m>"
        )


class Responder:
    """Base of the collision responders: the parameters the world needs to build rows, and
    ``respond``, the protocol (docs/your-responder.md). Subclass it to write your own:

        class MyPGS(phys2d.Responder):
            name, counts, warm_start = "my-pgs", "sweeps", True

            def respond(self, ctx):  # change ctx.V, leave ctx.rows.lam
                ...
                return phys2d.SolveResult(sweeps, residuals)

    ``phys2d check FILE.py:MyPGS`` grades it on the lecture's claims.

    beta    Baumgarte push factor (push = -(beta/dt) min(0, C + slop)), in [0, 1]
    slop    penetration allowed without push, m
    push_max  the largest push-out speed, m/s (Box2D v3's contactPushMaxVelocity)
    restitution_threshold  approach speed (m/s) above which contacts bounce
    warm_start  whether the world should start lambda from the contact cache
    handles_joints  whether joint rows may be given to this responder
    solves_mouse_joints  whether it solves mouse joints: their two rows (bound_row ``OWN_SOLVE``,
                    -2) are a soft pull with a solve of its own (``responders.mouse.solve_mice``)
    counts  the word for the work ``SolveResult.iterations`` counts: 'sweeps', 'passes', 'substeps'
    colour_order    visit contacts colour by colour (graph colouring, ``constraints.order``)
                    instead of in pair order: faster sweeps, a different Gauss-Seidel order;
                    part by part from ``PARTS_FROM`` moving bodies, as in part order
    part_order      visit contacts part by part, pair order within each (``constraints.order``):
                    a large scene's sweeps can then share the work among threads; a scene
                    of fewer than ``PARTS_FROM`` moving bodies keeps pair order exactly
    contacts_in_row_order  whether StepContext's contact arrays come gathered into row order;
                    False: the world's own, in contact order (``ctx.rows.order`` maps), for a
                    responder that gathers the few fields it reads in a kernel of its own
    lecture_take  (optional, a subclass's) which of the lecture's naive takes it is, 'naive' or
                    'iterative': the report card then notes the failures the lecture predicts
    found_lever_arms  build contact rows with the lever arms each manifold was found with
                    (``Contacts.anchor``: a recycled one keeps them) instead of p - x now;
                    see ``collision.recycle``. False keeps angular momentum exact: an
                    impulse then acts at one point of both bodies
    reads_targets   whether its tick reads the contact rows' targets and bounds (xi, push,
                    bounce, lo, hi, bound_row) and their JM. False (the soft step: its push
                    comes from C, its cone from mu) lets the world skip them in the
                    responder's own one-call tick; ``respond`` is always given them all
    kernel          the name of the compiled solve that does what its ``respond`` does
                    (``pipeline.context.KERNELS``: "pgs", "soft-step"), which the world then
                    runs inside its one-call tick with ``settings``; None (the default): the
                    world calls ``respond`` from Python, stage by stage. A class that writes its
                    own ``respond`` solves with it (kernel None) unless it names a kernel too
    respond_replaced  True once an instance is given a ``respond`` of its own (a test's spy,
                    say): the world then calls it, stage by stage, whatever ``kernel`` says
    version         counts the changes to its settings: the world reads them again when it moves
    """

    counts = "iterations"  # what StepReport.count counts for this responder
    beta = 0.2
    slop = 0.005
    push_max = 3.0
    restitution_threshold = 1.0
    warm_start = False
    handles_joints = False
    solves_mouse_joints = False
    colour_order = False
    part_order = False
    contacts_in_row_order = True
    found_lever_arms = False
    reads_targets = True
    kernel: str | None = None
    respond_replaced = False
    version = 0

    def __init_subclass__(cls, **kwargs: object) -> None:
        """A class that writes its own ``respond`` solves with it, unless it names its kernel too."""
        super().__init_subclass__(**kwargs)
        if "respond" in vars(cls) and "kernel" not in vars(cls):
            cls.kernel = None

    @property
    def visit_order(self) -> int:
        """The order the world hands this responder the contacts in (``constraints.order``):
        COLOUR_ORDER with ``colour_order``, else PART_ORDER with ``part_order``, else PAIR_ORDER."""
        return COLOUR_ORDER if self.colour_order else PART_ORDER if self.part_order else PAIR_ORDER

    def __setattr__(self, name: str, value: object) -> None:
        super().__setattr__(name, value)  # a Setting checks the value here
        if name == "respond":  # a respond of the instance's own (a test's spy, say): it solves with it
            object.__setattr__(self, "respond_replaced", True)
        object.__setattr__(self, "version", self.version + 1)  # the world reads its settings again

    def __delattr__(self, name: str) -> None:
        super().__delattr__(name)
        if name == "respond":  # the class's respond again: its kernel too
            object.__setattr__(self, "respond_replaced", False)
        object.__setattr__(self, "version", self.version + 1)

    @property
    def settings(self) -> object:
        """Its settings as its solve kernel reads them, plain values (``kernel``); None without one."""
        return None

    def _take(self, arguments: dict[str, object]) -> None:
        """Assign a constructor's arguments (its ``locals()``) in the signature's order, each
        checked by its Setting or setter, as a later assignment is."""
        for name, value in arguments.items():
            if name != "self" and not name.startswith("_"):
                setattr(self, name, value)

    @property
    def name(self) -> str:
        """The responder's name in reports (a subclass may set a plain class attribute)."""
        return "responder"

    @property
    def friction_model(self) -> int:
        """FRICTION_COULOMB or FRICTION_LECTURE: how the rows bound friction."""
        return FRICTION_COULOMB

    def respond(self, ctx: StepContext) -> SolveResult:  # pragma: no cover - interface
        """Solve one step's rows: the protocol every responder follows (docs/your-responder.md).

        Given (arrays are the world's own: edit in place):

            ctx.V           (N, 3) [vx, vy, omega] after the external forces (m/s, rad/s)
            ctx.M_inv       (N, 3) [1/m, 1/m, 1/I]; 0 for static bodies
            ctx.rows.J      (R, 6) row k's entries [J_a | J_b]; rows.body_a, rows.body_b its bodies
            ctx.rows.JM     (R, 6) M^-1 J_k^T: the velocity change of a, b per unit lambda_k
            ctx.rows.A_kk   (R,) J_k M^-1 J_k^T (0: both bodies static)
            ctx.rows.xi     (R,) the J_k V the row must reach (m/s): 0 touching, -C/dt still
                            apart, a touching contact's bounce, a joint motor's speed
            ctx.rows.push   (R,) the Baumgarte push (m/s): a touching contact's push-out
                            speed, a joint's -(beta/dt) C; the lecture's target is xi + push
            ctx.rows.lo, hi (R,) fixed bounds on lambda_k (N s), for rows with bound_row = -1
            ctx.rows.bound_row, mu  a friction row's normal row (>= 0) and coefficient: its
                            bounds are +-mu[k] * lam[bound_row[k]]; -2 marks a mouse joint's
                            rows (only for a responder with ``solves_mouse_joints``)
            ctx.rows.lam    (R,) with ``warm_start``: last step's impulses (N s), not yet in V

        To do: apply the warm start, V += M^-1 J^T lambda (``JM[k] * lam[k]`` on bodies a, b);
        sweep the rows, clamping each accumulated lambda_k into its bounds; leave each row's
        impulse in ``ctx.rows.lam`` (N s); return ``SolveResult(iterations, residuals)``, the
        work done (counted in ``counts``) and each one's residual (m/s).

        After it, unless ``SolveResult.integrated`` says the responder moved ``ctx.x`` and
        ``ctx.theta`` itself, the world moves them (x += dt v, theta += dt omega) and bounces
        the contacts that met their partner within the step (``ctx.rows.bounce``). It refuses a
        non-finite or too fast state (``SimulationError``), and a step that fails, or whose
        ``respond`` raises, leaves the world as before it. Then it reports and caches
        ``ctx.rows.lam``.
        """
        raise NotImplementedError
