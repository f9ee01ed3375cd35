"""Lesson 1: the naive take - one impulse per colliding pair, then push apart.

Claim (lecture, "Naive take"): the impulse

    f = -(1 + e) (J_n V) / (1/m_a + 1/m_b + (r_a x n)^2 / I_a + (r_b x n)^2 / I_b)

applied once per pair and tick is the law of conservation of momentum for one
collision, and it is right for an isolated pair. But it "jitters a lot, and does
not support stacking": boxes on the ground never come to rest, and a stack falls.

Part 1 checks the formula, worked by hand here, against the engine on three
pairs in zero gravity. Part 2 runs dropped boxes and an 8-box stack and measures
the jitter (kinetic energy that never settles) and the penetration.

In the viewer: run "drops" - the boxes keep twitching on the ground and
stats/energy never reaches 0; run "stack" - the column sinks into itself and
topples. The contacts are red (new) every tick: nothing is remembered.
"""

import _common as c
import numpy as np

import phys2d


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def normal_speed(x, V, p, n):
    """J_n V: (v_b + omega_b x r_b - v_a - omega_a x r_a) . n for bodies a=0, b=1 at point p."""
    r_a, r_b = p - x[0], p - x[1]
    vel_a = V[0, :2] + V[0, 2] * np.array([-r_a[1], r_a[0]])
    vel_b = V[1, :2] + V[1, 2] * np.array([-r_b[1], r_b[0]])
    return np.dot(vel_b - vel_a, n)


def lecture_impulse(x, V, M_inv, p, n, e):
    """The lecture's f for bodies 0 and 1 at point p, normal n (0 -> 1), and V after it.

    The slide updates v_A+ = v_A- + f N0 / m_A and v_B+ = v_B- - f N0 / m_B with its relative
    normal velocity (v_A - v_B) . N0. phys2d's n points from a to b, so the slide's N0 is -n
    (from B towards A): then (v_A - v_B) . N0 = (v_B - v_A) . n = J_n V, and body a gets -f n,
    body b +f n, as below."""
    r_a, r_b = p - x[0], p - x[1]
    f = (
        -(1 + e)
        * normal_speed(x, V, p, n)
        / (M_inv[0, 0] + M_inv[1, 0] + cross(r_a, n) ** 2 * M_inv[0, 2] + cross(r_b, n) ** 2 * M_inv[1, 2])
    )
    V_after = V.copy()
    V_after[0] += M_inv[0] * np.array([-f * n[0], -f * n[1], -cross(r_a, f * n)])
    V_after[1] += M_inv[1] * np.array([f * n[0], f * n[1], cross(r_b, f * n)])
    return f, V_after


def pair(kind):
    """A zero-gravity world with one pair about to collide (bodies 0 and 1), and its e."""
    w = phys2d.World(gravity=(0, 0), responder=phys2d.NaiveImpulse())
    if kind == "equal circles, e=1":
        w.add_circle(position=(0, 0), radius=0.5, velocity=(2, 0), restitution=1.0, friction=0)
        w.add_circle(position=(0.95, 0.3), radius=0.5, velocity=(-1, 0), restitution=1.0, friction=0)
        return w, 1.0
    if kind == "light vs heavy, e=0.5":
        w.add_circle(position=(0, 0), radius=0.3, velocity=(3, 1), restitution=0.5, friction=0)
        w.add_circle(position=(0.99, 0), radius=0.7, density=5.0, restitution=0.5, friction=0)
        return w, 0.5
    # a tilted box lands on one corner on static ground: the impulse makes it spin
    w.add_box(position=(0, -0.5), half_extents=(5, 0.5), static=True, friction=0.0)
    h = 0.5 * (np.cos(0.4) + np.sin(0.4))  # corner height above the centre
    w.add_box(position=(0, h - 0.005), angle=0.4, velocity=(0.5, -3), friction=0.0, restitution=0.3)
    return w, 0.3


args = c.options(__doc__)
c.claim(
    "the lecture's impulse is momentum conservation for one pair, yet applied pair by pair it jitters and cannot stack"
)
print("Part 1: the formula by hand against the engine (one step, zero gravity)")
rows = []
for kind in ("equal circles, e=1", "light vs heavy, e=0.5", "tilted box on its corner, e=0.3"):
    w, e = pair(kind)
    x0, V0, p0 = w.x.copy(), w.V.copy(), w.linear_momentum()
    w.step(c.DT)  # collide at x0; the pair's impulse; push apart; move
    ct = w.contacts
    f, V_hand = lecture_impulse(x0, V0, w.M_inv, ct.point[0], ct.normal[0], e)
    bounce = normal_speed(x0, w.V, ct.point[0], ct.normal[0]) / normal_speed(x0, V0, ct.point[0], ct.normal[0])
    dp = "static ground" if w.M_inv[0, 0] == 0 else np.abs(w.linear_momentum() - p0).max()
    rows.append([kind, f, ct.normal_impulse.sum(), np.abs(V_hand - w.V).max(), bounce, dp])
c.table(
    [
        "pair",
        "f by hand (N s)",
        "f engine (N s)",
        "max |V+ hand - V+ engine|",
        "J_n V+ / J_n V-",
        "|momentum change| (kg m/s)",
    ],
    rows,
)
print("  (J_n V+ / J_n V- = -e: the pair leaves at e times the speed it came in)")
seconds = 3.0 if args.quick else 10.0
last = round(1.0 / c.DT)  # ticks in the last second
print(f"\nPart 2: NaiveImpulse on dropped boxes and an 8-box stack, {seconds:g} s at dt = 1/60 s")


def probe(w):
    return [w.kinetic_energy(), w.last_step.max_penetration]


with c.recorder(args, __file__, "lesson 1: naive impulse") as rec:
    drops = c.simulate(c.dropped_boxes(phys2d.NaiveImpulse()), seconds, rec, "drops", probe)
    w = c.zigzag_stack(phys2d.NaiveImpulse())
    y0 = w.x[:, 1].copy()
    stack = c.simulate(w, seconds, rec, "stack", probe)
print(
    f"drops: kinetic energy over the last second: mean {drops[-last:, 0].mean():.3g} J, "
    f"max {drops[-last:, 0].max():.3g} J (at rest it would be 0)"
)
print(f"drops: penetration over the last second: max {drops[-last:, 1].max():.3g} m")
print(
    f"stack: top box height {y0[-1]:.3f} m -> {w.x[-1, 1]:.3f} m; boxes standing: {c.standing(w, y0)} of {len(w) - 1}"
)
print(
    f"stack: max penetration {stack[:, 1].max():.3g} m; kinetic energy over the last second: "
    f"mean {stack[-last:, 0].mean():.3g} J"
)
print(
    "TAKEAWAY: one exact impulse per pair and tick conserves momentum pair by pair, but the "
    f"boxes never settle ({drops[-last:, 0].mean():.2g} J left) and the stack keeps "
    f"{c.standing(w, y0)} of {len(w) - 1} boxes up"
)
c.done(rec)
