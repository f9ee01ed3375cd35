"""Soft step: sub-stepping with soft contacts and relaxation (Box2D v3's solver).

What the field learned after the lecture, kept beside its PGS, not in place of it.
The tick of length dt is split into n sub-steps of h = dt/n. The stages carry
Box2D v3's names:

    prepare                                  lever arms (as each manifold was found: a recycled
                                             one keeps them); once per tick, per manifold, what
                                             the sweeps reuse (``prepare_manifolds``); per
                                             sub-step, the joint rows at the positions now (and
                                             their factor)
    integrate velocities  V += h M^-1 F_ext  external forces, a slice at a time
    warm start            V += M^-1 J^T lam  the impulse per sub-step
    solve (with bias)                        joint rows, then one PGS sweep of the contacts
                                             with a soft push
    integrate positions   x += h v, theta += h omega
    relax                                    the same without the push: remove its velocity
    store                                    add the sub-step's impulses to the tick's

and after the last sub-step one restitution pass: the points that met their partner
faster than the threshold bounce from their approach at impact, taken in the
sub-step where they first pushed. The relax sweep leaves points still apart alone (the
next sweep with the push limits their approach), and an impact's impulse is not warm
started into the next sub-step: it was an event, not a load.

A heavy body on a light one, or a tall stack, converges because each sub-step only has
to correct a sub-step's worth of gravity. The stages live by idea: the tick's contact
points in ``soft_points``, the soft push and the contacts' sweep in ``soft_contacts``, the
joints in ``soft_joints``, the sub-steps' integration in ``soft_integrate``; this module runs
them (``soft_step_solve``).

The kernels take records (``phys2d.pipeline.records``), a few arguments each: the bodies,
the rows, the tick's contact points (``Points``) and the joints, which are None in a world
without them, so that none of the joints' code is compiled there.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..constraints.joints import JointArrays
from ..constraints.rows import unsigned_rows
from ..jit import njit
from ..pipeline import records
from ..pipeline.parallel import (
    groups_for,
    integrate_positions_on,
    note_impacts_on,
    prepare_manifolds_on,
    prepare_points_on,
    soft_sweep_in_groups,
    store_on,
    warm_start_in_groups,
)
from ..validation import Setting, check_bool, check_int, non_negative_float
from .base import Responder, SolveResult, StepContext
from .block import inverse_diagonal
from .mouse import solve_mice
from .soft_contacts import (
    soft_constants,
    soft_friction_rows,
    soft_normal_rows,
    warm_start_joints,
    warm_start_manifolds,
)
from .soft_integrate import integrate_velocities, split_forces
from .soft_joints import first_joint_row_of, joint_system, prepare_joints, solve_joints
from .soft_points import note_sweep_start, restitution


class SoftSettings(NamedTuple):
    """A ``SoftStep``'s settings as its kernel reads them (see ``SoftStep``)."""

    substeps: int
    relax: bool
    contact_hertz: float
    damping_ratio: float
    push_max: float
    joint_hertz: float
    joint_damping_ratio: float
    direct_joints: bool
    restitution_threshold: float
    block: bool


@njit(cache=True)
def soft_step_solve(bodies, rows, found, joints, dt, settings, residuals, threads):
    """The whole tick, Box2D v3's stages: prepare, then per sub-step integrate velocities,
    warm start, solve with bias, integrate positions, relax (the same sweep without bias),
    store; then restitution.

    bodies: a BodyRecord (V after the external forces, V1 before); rows: the step's rows, the
    K contacts' first (row pair q is contact order[q]), then the joints' from row 2K;
    found: (order, separation, e) of the K contacts, in contact order; joints: a
    JointRecord, or None for a world without joints (then no joint code is compiled: numba
    drops the ``joints is not None`` branches); settings: a ``SoftSettings``.

    ``RowRecord.lam`` holds the cached impulse per tick going in and the impulse over the whole tick
    (N s) coming out; within the tick it is the impulse per sub-step (warm start in, last
    sub-step out). Joint rows are rebuilt at each sub-step's positions. Returns the number of
    sub-steps; residuals[s] (length ``substeps``, the caller's buffer) is the largest correction
    of sub-step s's relax sweep (m/s), 0 without one. threads: None on one thread (no parallel
    code is compiled), else (count, each body's part of the solve order, ``constraints.order``):
    the contacts' sweeps run on several (``pipeline.parallel``), with the same results.
    """
    x, theta, V, M_inv = bodies.x, bodies.theta, bodies.V, bodies.M_inv
    substeps, relax, threshold = settings.substeps, settings.relax, settings.restitution_threshold
    n_rows = rows.lam.shape[0]
    n_contacts = rows.normal_row.shape[0]
    h = dt / substeps
    hertz = min(settings.contact_hertz, 0.25 / h)
    springs = (
        soft_constants(hertz, settings.damping_ratio, h, settings.push_max),  # contacts between dynamic bodies
        soft_constants(2.0 * hertz, settings.damping_ratio, h, settings.push_max),  # contacts with a static body
        soft_constants(min(settings.joint_hertz, 0.25 / h), settings.joint_damping_ratio, h, np.inf),  # joints
    )
    # prepare
    joint_rows_in = rows  # the joints' rows are rebuilt in these (signed, as joint_rows is compiled for)
    rows = unsigned_rows(rows)
    lam = rows.lam
    for k in range(n_rows):
        lam[k] /= substeps  # cached impulse per tick -> per sub-step
    total = np.zeros(n_rows)
    manifolds = prepare_manifolds_on(threads, rows, M_inv, settings.block)
    groups = groups_for(threads, manifolds[0], rows, M_inv)  # None on one thread
    inv_A_kk = inverse_diagonal(rows.A_kk)  # the contact rows' A_kk hold over the tick (joint rows do not use it)
    x0 = x.copy()
    theta0 = theta.copy()
    points = prepare_points_on(threads, found, x.shape[0])
    moved = points.moved  # per body: dx, dy, cos dtheta, sin dtheta since the tick began
    system = joint_system(joints, rows, settings.direct_joints)
    dv = split_forces(bodies, substeps)
    n_manifolds = manifolds[0].shape[0] - 1
    n_pending = n_contacts  # the points not yet met: their approach is still to come
    n_sweeps = 0
    for i in range(substeps):
        if joints is not None and n_rows > first_joint_row_of(rows):
            prepare_joints(joints, bodies, joint_rows_in, system)
        for sweep in range(2 if relax else 1):  # with bias, then the relax sweep without
            with_bias = sweep == 0
            new_C = not with_bias or (i > 0 and not relax)  # (after a relax sweep the positions have not moved)
            if n_pending > 0:  # the approach of the points not yet met, as the sweep begins
                note_sweep_start(points, V)
            if with_bias:
                integrate_velocities(V, dv)
                if threads is None:  # ``warm_start``'s two parts
                    warm_start_manifolds(0, n_manifolds, manifolds[0], rows, M_inv, V)
                    warm_start_joints(rows, V)
                else:
                    warm_start_in_groups(groups, manifolds, rows, M_inv, V)
            # solve: joints first, contacts last (they have the last word on overlap). Written out
            # here: a function of its own would count a reference to each array it is handed, at
            # every sweep, around each call that may raise
            worst = 0.0
            if joints is not None and n_rows > first_joint_row_of(rows):
                worst = solve_joints(rows, system, V, h, with_bias, springs[2])
                worst = max(worst, solve_mice(joints, first_joint_row_of(rows), rows, V, h, 1.0))  # (rows of dt = 1)
            if threads is None:  # ``soft_sweep``'s two passes (numba drops the branch not taken)
                worst = max(worst, soft_normal_rows(
                    0, n_manifolds, rows, manifolds, inv_A_kk, points, M_inv, V, h, with_bias, springs, new_C
                ))  # fmt: skip
                worst = max(worst, soft_friction_rows(0, n_manifolds, rows, manifolds, inv_A_kk, points, M_inv, V, h))
            else:  # its groups on several threads (``pipeline.parallel``)
                worst = max(worst, soft_sweep_in_groups(
                    groups, rows, manifolds, inv_A_kk, points, M_inv, V, h, (with_bias, new_C), springs
                ))  # fmt: skip
            if n_pending > 0:  # relax stops what would close a gap in the next sub-step's motion: an impact too
                n_pending = note_impacts_on(threads, rows, points, n_pending, dv, h, threshold)
            if with_bias:
                integrate_positions_on(threads, bodies, h, x0, theta0, moved)
            residuals[n_sweeps] = 0.0 if with_bias else worst  # the relax sweep's, when there is one
        n_sweeps += 1
        store_on(threads, rows, total, points)
    restitution(rows, points, threshold, total, V, M_inv)
    for k in range(n_rows):
        lam[k] = total[k]
    return n_sweeps


class SoftStep(Responder):
    """Sub-stepped soft-contact solver (Box2D v3's "soft step"): stable stacks, mass ratios, joints.

    substeps       sub-steps per tick (each: one sweep with the soft push, one relax sweep)
    relax          run the relax sweep that removes the push's velocity
    contact_hertz  stiffness of the contact spring (Hz); capped at a quarter of the sub-step rate
    damping_ratio  zeta of the contact spring (10: heavily over-damped, no bounce from the push)
    push_max       largest velocity the push may give an overlapping point (m/s)
    joint_hertz    stiffness of the joints' pull back to C = 0 (Hz), capped like contact_hertz
    joint_damping_ratio  zeta of that pull
    direct_joints  solve the equality joint rows (pins, rods, fixed angles) together, exactly,
                   in each sweep (a Cholesky factor of their A, refreshed every sub-step) instead
                   of one by one; the pull keeps its rate, the rows are rigid
    restitution_threshold  approach speed (m/s) above which e applies
    warm_start     start each sub-step from last tick's impulse per sub-step
    block          solve a two-point manifold's normal rows together (see ``soft_sweep``)

    Friction is Coulomb's (|lambda_t| <= mu lambda_n). Joints' rows are rebuilt at every
    sub-step's positions; angle limits are one-sided rows treated like contact points.
    Contact rows take the lever arms each manifold was found with (``found_lever_arms``;
    a recycled manifold keeps them, as in Box2D v3, ``collision.recycle``): a 20-box stack
    leaning 1 mm a box stands, where arms turned with the boxes let it buckle. Angular
    momentum is then kept to within lambda times how far a point's two arms have parted.
    """

    name = "soft-step"
    kernel = "soft-step"  # its solve is ``soft_step_solve``, in the world's one-call tick
    counts = "substeps"
    handles_joints = True
    solves_mouse_joints = True
    colour_order = True  # measured: steadier tall piles than pair order, and faster sweeps
    contacts_in_row_order = False  # it gathers the two fields it reads itself (gather_contacts)
    found_lever_arms = True  # measured: a 1 mm leaning 20-stack stands (it buckled with arms p - x)
    reads_targets = False  # its push and cone come from C and mu; it forms M^-1 J^T from J
    beta = 0.0  # the rows' Baumgarte terms are not used: the push is soft
    slop = 0.0

    substeps = Setting(lambda v, name: check_int(v, name, 1), "sub-steps per tick")
    relax = Setting(check_bool, "run the relax sweep")
    contact_hertz = Setting(non_negative_float, "contact spring stiffness, Hz")
    damping_ratio = Setting(non_negative_float, "contact spring damping ratio")
    push_max = Setting(non_negative_float, "largest push-out speed, m/s")
    joint_hertz = Setting(non_negative_float, "joint spring stiffness, Hz")
    joint_damping_ratio = Setting(non_negative_float, "joint spring damping ratio")
    direct_joints = Setting(check_bool, "solve the equality joint rows together, exactly")
    restitution_threshold = Setting(non_negative_float, "approach speed (m/s) above which e applies")
    warm_start = Setting(check_bool, "start from last tick's impulses")
    block = Setting(check_bool, "solve two-point manifolds as 2x2 blocks")

    def __init__(
        self,
        substeps: int = 4,
        relax: bool = True,
        contact_hertz: float = 30.0,
        damping_ratio: float = 10.0,
        push_max: float = 3.0,
        restitution_threshold: float = 1.0,
        warm_start: bool = True,
        block: bool = True,
        joint_hertz: float = 60.0,
        joint_damping_ratio: float = 2.0,
        direct_joints: bool = True,
    ) -> None:
        self._take(locals())

    @property
    def settings(self) -> SoftSettings:
        """The settings as ``soft_step_solve`` reads them."""
        return SoftSettings(
            self.substeps, self.relax, self.contact_hertz, self.damping_ratio, self.push_max, self.joint_hertz,
            self.joint_damping_ratio, self.direct_joints, self.restitution_threshold, self.block,
        )  # fmt: skip

    def respond(self, ctx: StepContext) -> SolveResult:
        rows = ctx.rows
        bodies = records.new_bodies((ctx.x, ctx.theta, ctx.V, ctx.M_inv, ctx.V1))
        found = (rows.order, ctx.separation, ctx.restitution)
        joints = None  # a world without joints compiles none of their code
        if isinstance(ctx.joints, JointArrays) and ctx.joints.kind.shape[0] > 0:
            joints = records.record_of_joints(ctx.joints, rows.lam[rows.first_joint_row :])  # (lam: not read)
        residuals = np.zeros(self.substeps)
        threads = None  # one thread: no parallel code compiled
        if ctx.threads > 1:  # (without the parts every manifold is in part 0: solved on one thread)
            threads = (ctx.threads, ctx.part if ctx.part is not None else np.zeros(ctx.x.shape[0], np.int32))
        settings = self.settings
        n = soft_step_solve(bodies, records.record_of_rows(rows), found, joints, ctx.dt, settings, residuals, threads)
        return SolveResult(n, residuals[:n], integrated=True)

    def __repr__(self) -> str:
        return (
            f"SoftStep(substeps={self.substeps}, relax={self.relax}, contact_hertz={self.contact_hertz:g}, "
            f"damping_ratio={self.damping_ratio:g}, push_max={self.push_max:g}, warm_start={self.warm_start}, "
            f"block={self.block}, joint_hertz={self.joint_hertz:g}, "
            f"joint_damping_ratio={self.joint_damping_ratio:g}, direct_joints={self.direct_joints})"
        )


__all__ = ["SoftSettings", "SoftStep", "soft_step_solve"]
