"""Lesson 3: constraints as rows of J, and the chain rule C' = J V.

Claim (lecture, "Constraints"): every constraint C(x) = 0 is a function of the
positions, so by the chain rule its rate is C' = J V, with one row of J per
constraint. A row between bodies i and j has 6 non-zeros (docs/formulation.md):

    contact    [-n, -(r_i x n) | n, r_j x n]        C = (x_j + r_j - x_i - r_i) . n
    friction   [-t, -(r_i x t) | t, r_j x t]        no C: the rate of slip along t
    distance   [-d, -(r_i x d) | d, r_j x d]        C = 1/2 (|p_j - p_i|^2 - L^2)
    angle      [0, 0, -1 | 0, 0, 1]                 C = theta_j - theta_i - theta_0

One concrete pair: box j resting on box i, joined also by a distance joint and
an angle joint. The engine's rows are printed, then J V (for a random V) is
checked against the numerical derivative of C by central differences, with C
and the points moved exactly as rigid bodies move (the contact normal turns with
body i, as in the lecture).

In the viewer: the two boxes tumble with their initial random velocity; the rod
of the distance joint (world/sim/joints) keeps its length, the boxes keep their
relative angle, and contacts/lambda_n shows the contact pushing.
"""

import _common as c
import numpy as np

import phys2d


def R(theta):
    return np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


def make():
    w = phys2d.World(gravity=(0, 0), responder=phys2d.PGS(form="matrix"))
    i = w.add_box(position=(0, 0), half_extents=(1.0, 0.5), angle=0.2)
    j = w.add_box(position=R(0.2) @ (-0.1, 0.995), angle=0.2)  # resting on i, 5 mm into it
    w.add_distance_joint(i, j, anchor_a=(-0.9, 0.2), anchor_b=(0.3, 1.3), collide_connected=True)
    w.add_angle_joint(i, j, collide_connected=True)
    return w


args = c.options(__doc__)
c.claim("each constraint is a row of J, and J V is the time derivative of C (the chain rule)")
w = make()
x0, th0 = w.x.copy(), w.theta.copy()
w.step(c.DT)
J = w.last_step.system.dense().J  # rows built at x0, th0: 2 per contact point, then the joints
first = w.last_step.solve_order[0]  # rows 0 and 1 are this contact point's (normal, friction)
p, n, s = w.contacts.point[first], w.contacts.normal[first], w.contacts.separation[first]
t = np.array([-n[1], n[0]])
dist, angle = w.joints
k_dist = 2 * len(w.contacts)  # the joint rows follow the contact rows
names = {0: "contact", 1: "friction", k_dist: "distance", k_dist + 1: "angle"}
print(
    f"bodies i=0, j=1; rows 0, 1: contact point {first}, p = ({p[0]:.3f}, {p[1]:.3f}) m, "
    f"n = ({n[0]:.3f}, {n[1]:.3f}), separation C = {s:.4f} m"
)
c.table(
    ["row", "J_i: x", "y", "omega", "J_j: x", "y", "omega"],
    [[name] + list(J[k]) for k, name in names.items()],
    "{:+.3f}",
)


def world(x, th, b, q):
    """Where point q of body b (q given at the pose x0, th0) is when the bodies are at x, th."""
    return x[b] + R(th[b]) @ R(-th0[b]) @ (q - x0[b])


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


pa = x0[0] + R(th0[0]) @ dist.local_a
pb = x0[1] + R(th0[1]) @ dist.local_b
L = dist.length
C = {
    "contact": lambda x, th: s + (world(x, th, 1, p) - world(x, th, 0, p)) @ (R(th[0] - th0[0]) @ n),
    "friction": lambda x, th: (world(x, th, 1, p) - world(x, th, 0, p)) @ t,
    "distance": lambda x, th: 0.5 * (np.sum((world(x, th, 1, pb) - world(x, th, 0, pa)) ** 2) - L**2),
    "angle": lambda x, th: th[1] - th[0] - angle.theta_0,
}
V = np.random.default_rng(3).normal(size=(2, 3))  # any velocities will do: [vx, vy, omega] per body
h = 1e-6
rows = []
for k, name in names.items():
    Cdot = (C[name](x0 + h * V[:, :2], th0 + h * V[:, 2]) - C[name](x0 - h * V[:, :2], th0 - h * V[:, 2])) / (2 * h)
    JV = J[k] @ V.ravel()
    if name == "distance":  # the engine stores the lecture's row divided by L (docs/formulation.md)
        JV *= L
    rows.append([name, JV, Cdot, abs(JV - Cdot)])
c.table(["row", "J V", "dC/dt (finite difference)", "|difference|"], rows, "{:+.6g}")
d = pb - pa
lecture_row = np.concatenate([-d, [-cross(pa - x0[0], d)], d, [cross(pb - x0[1], d)]])
print(
    f"distance: the lecture's row [-d, -(r_i x d) | d, r_j x d] / the engine's row = "
    f"{np.mean(lecture_row / J[k_dist]):.4f} = L = {L:.4f} m"
)
worst = max(r[3] for r in rows)
print(f"TAKEAWAY: J V matches dC/dt on every row to {worst:.1g} (finite differences with h = {h:g} s)")

seconds = 1.0 if args.quick else 4.0
w = make()
w.V[:] = V
dist, angle = w.joints
with c.recorder(args, __file__, "lesson 3: constraints and Jacobians") as rec:
    gap = c.simulate(w, seconds, rec, probe=lambda w: [dist.gap(), abs(angle.offset())])
print(
    f"moving for {seconds:g} s from that V: distance joint off by at most {gap[:, 0].max():.2g} m, "
    f"angle joint by {gap[:, 1].max():.2g} rad"
)
c.done(rec)
