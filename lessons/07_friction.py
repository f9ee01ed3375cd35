"""Lesson 7: friction - the lecture's fixed bound against Coulomb's mu lambda_n.

Claim (lecture, "Friction constraints"): friction rows are contact rows along
the tangent, bounded by -mu m_c g <= lambda_t <= mu m_c g, "an approximation".
docs/formulation.md uses Coulomb's bound |lambda_t| <= mu lambda_n instead (lambda_n:
the same point's normal impulse). They agree for one box on flat ground; the
fixed bound ignores the slope (it uses g, not g cos(alpha)) and any load on top.

A box (mu = 0.5) on ramps of 20, 28 and 35 degrees: Coulomb holds it while
tan(alpha) <= mu and then accelerates it at g (sin(alpha) - mu cos(alpha)); the
lecture's bound holds it while sin(alpha) <= mu and gives g (sin(alpha) - mu).
A box sliding at 4 m/s on flat ground, alone and with a second box riding on
it: the analytic stopping distance is v^2 / (2 mu g); semi-implicit Euler moves
each tick with the velocity after the tick, so it stops v dt / 2 short of it.

In the viewer: runs ramp28-coulomb (slides) and ramp28-lecture (stuck) side by
side; slide-loaded-lecture travels twice as far as slide-loaded-coulomb.
Plot contacts/lambda_t against contacts/lambda_n.
"""

import _common as c
import numpy as np

import phys2d

MU, G, V0 = 0.5, 10.0, 4.0
args = c.options(__doc__)
ramp_time, slide_time = (1.5, 2.5) if args.quick else (4.0, 4.0)
c.claim(
    "Coulomb's bound mu lambda_n gives the textbook ramp and sliding figures; the lecture's fixed "
    "mu m_c g ignores slope and load"
)


def R(a):
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def ramp(alpha, friction):
    w = phys2d.World(gravity=(0, -G), responder=phys2d.PGS(iterations=50, friction=friction))
    w.add_box(position=(0, 0), half_extents=(30, 0.5), angle=alpha, static=True, friction=MU)
    w.add_box(position=R(alpha) @ (0, 1.0), angle=alpha, friction=MU)  # resting on the slope
    return w


def slide(friction, loaded):
    w = phys2d.World(gravity=(0, -G), responder=phys2d.PGS(iterations=50, friction=friction))
    phys2d.scenes.ground(w, friction=MU)
    w.add_box(position=(0, 0.5), velocity=(V0, 0), friction=MU)
    if loaded:
        w.add_box(position=(0, 1.5), velocity=(V0, 0), friction=MU)
    return w


rows = []
with c.recorder(args, __file__, "lesson 7: friction") as rec:
    for deg in (20, 28, 35):
        a = np.radians(deg)
        down = -R(a) @ (1, 0)  # down the slope
        expect = {"coulomb": G * max(0.0, np.sin(a) - MU * np.cos(a)), "lecture": G * max(0.0, np.sin(a) - MU)}
        for friction in ("coulomb", "lecture"):
            w = ramp(a, friction)
            v = c.simulate(w, ramp_time, rec, f"ramp{deg}-{friction}", lambda w, down=down: w.V[1, :2] @ down)
            accel = (v[-1] - v[round(0.5 / c.DT)]) / (ramp_time - 0.5 - c.DT)  # after half a second
            rows.append([f"{deg} deg, {friction}", accel, expect[friction]])
    print(
        f"ramp, mu = {MU}: tan(28 deg) = {np.tan(np.radians(28)):.3f} > mu > sin(28 deg) = {np.sin(np.radians(28)):.3f}"
    )
    c.table(["ramp, bound", "measured accel (m/s^2)", "analytic (m/s^2)"], rows, "{:.4f}")

    rows = []
    for loaded in (False, True):
        for friction in ("coulomb", "lecture"):
            w = slide(friction, loaded)
            m1, m_all = w.bodies[1].mass, sum(b.mass for b in w.bodies[1:])
            # decelerating force on the bottom box from the ground: Coulomb mu m_all g; the lecture's
            # bound mu m_c g with m_c = m1 (the static ground's partner), whatever rides on top
            decel = MU * G * (1.0 if friction == "coulomb" else m1 / m_all)
            vx = c.simulate(
                w, slide_time, rec, f"slide-{'loaded' if loaded else 'alone'}-{friction}", lambda w: w.V[1, 0]
            )
            stopped = np.flatnonzero(np.abs(vx) < 1e-6)
            d = V0**2 / (2 * decel)
            rows.append(
                [
                    f"{'loaded' if loaded else 'alone'}, {friction}",
                    w.x[1, 0],
                    d,
                    d - V0 * c.DT / 2,
                    (stopped[0] + 1) * c.DT if stopped.size else np.nan,
                    V0 / decel,
                ]
            )
print(f"sliding at {V0} m/s on flat ground, mu = {MU}, dt = 1/60 s:")
c.table(
    ["box, bound", "stopped after (m)", "v^2/(2 a) (m)", "minus v dt/2 (m)", "stop time (s)", "v / a (s)"],
    rows,
    "{:.4f}",
)
alone, loaded = rows[0], rows[3]
print(
    f"TAKEAWAY: Coulomb matches the analytic ramp accelerations and stops the box at {alone[1]:.4f} m = "
    f"v^2/(2 mu g) - v dt/2 = {alone[3]:.4f} m; the lecture's bound lets a loaded box slide "
    f"{loaded[1]:.3f} m instead of {rows[2][1]:.3f} m, because it never sees the load"
)
c.done(rec)
