"""What every responder follows, and the report a step leaves behind.

A responder turns the constraint rows of a step into impulses: it changes the
velocities V in place, and may move positions itself (push-apart, split push,
sub-steps, the restitution pass after the move). The world builds the rows with
the responder's own Baumgarte factor, slop, push cap, bounce threshold and friction
model, fills ``rows.lam`` with the cached impulses when the responder asks for warm
starting, calls ``respond`` and reads the impulses back from ``rows.lam``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

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
    body_a: np.ndarray  # (K,) contact bodies (for responders that work pair by pair)
    body_b: np.ndarray
    point: np.ndarray  # (K, 2) contact points p, m
    normal: np.ndarray  # (K, 2) from a to b
    separation: np.ndarray  # (K,) m, negative when overlapping
    restitution: np.ndarray  # (K,) mixed e of each contact
    gravity: np.ndarray | None = None  # (2,) m/s^2, the only external force
    joints: object = None  # the world's packed joints (``JointArrays``), for responders that rebuild joint rows

    @property
    def F_ext(self) -> np.ndarray:
        """(N, 3) external forces and torques [f_x, f_y, tau] (N, N m): m g on dynamic bodies."""
        F = np.zeros(self.M_inv.shape)
        if self.gravity is not None:
            dyn = self.M_inv[:, 0] > 0.0
            F[dyn, :2] = self.gravity / self.M_inv[dyn, 0:1]
        return F


@dataclass(eq=False)
class SolveResult:
    iterations: int
    residuals: np.ndarray  # (iterations,) largest velocity correction of each sweep, m/s
    system: object = None  # the assembled matrix system, for responders that build one
    integrated: bool = False  # True if the responder moved the positions itself (sub-steps, or a pass after)


@dataclass(eq=False)
class StepReport:
    """What the last ``World.step`` did (``w.last_step``).

    residuals[k] is the largest velocity correction |delta lambda_k| A_kk (m/s) any
    row needed in sweep k: it falls towards 0 as the iterations converge.
    """

    responder: str = "none"
    dt: float = 0.0
    iterations: int = 0
    residuals: np.ndarray = field(default_factory=lambda: np.zeros(0))
    max_penetration: float = 0.0  # m, the deepest overlap at collision time
    contact_count: int = 0
    cache_hits: int = 0
    joint_impulses: np.ndarray = field(default_factory=lambda: np.zeros(0))
    system: object = None
    solve_order: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    # the q-th contact visited (and given the q-th pair of rows of the step's system) is solve_order[q]

    def read_only(self) -> StepReport:
        """Make the report's arrays (and its system's) read-only, and return self."""
        for a in (self.residuals, self.joint_impulses, self.solve_order):
            a.flags.writeable = False
        if self.system is not None:
            self.system.read_only()
        return self

    @property
    def cache_hit_rate(self) -> float:
        """Fraction of this step's contacts found in the cache (1.0 when there were none)."""
        return self.cache_hits / self.contact_count if self.contact_count else 1.0

    def __repr__(self) -> str:
        res = f"{self.residuals[-1]:.3g} m/s" if self.residuals.size else "-"
        return (f"<StepReport {self.responder}: {self.contact_count} contacts, "
                f"{self.cache_hits} cached, {self.iterations} iterations, final residual {res}, "
                f"max penetration {self.max_penetration:.4g} m>")


class Responder:
    """Base of the collision responders: the parameters the world needs to build rows.

    beta    Baumgarte push factor (push = -(beta/dt) min(0, C + slop)), in [0, 1]
    slop    penetration allowed without push, m
    push_max  the largest push-out speed, m/s (Box2D v3's contactPushMaxVelocity)
    restitution_threshold  approach speed (m/s) above which contacts bounce
    warm_start  whether the world should start lambda from the contact cache
    handles_joints  whether joint rows may be given to this responder
    colour_order    visit contacts colour by colour (graph colouring, ``constraints.order``)
                    instead of in pair order: faster sweeps, a different Gauss-Seidel order
    """

    name = "responder"
    beta = 0.2
    slop = 0.005
    push_max = 3.0
    restitution_threshold = 1.0
    warm_start = False
    handles_joints = False
    colour_order = False
    friction_model = FRICTION_COULOMB

    def respond(self, ctx: StepContext) -> SolveResult:  # pragma: no cover - interface
        raise NotImplementedError
