/*
 * A small C harness around Box2D v3, loaded by benchmarks/engines.py through ctypes.
 *
 * phys2d's own code (not Box2D's): it only calls Box2D v3's public API
 * (include/box2d/box2d.h). peers.py compiles it together with a Box2D v3
 * static library into one shared library; see Box2DV3Adapter in engines.py.
 *
 * One world per harness. Bodies get indices 0, 1, 2, ... in creation order (the
 * ground is made by the caller like any other static box). Units are SI: m, kg,
 * s, rad. Every function that takes a body index trusts the caller to pass one
 * that exists: the Python adapter is the only caller.
 */

#include "box2d/box2d.h"

#include <math.h>
#include <stdlib.h>

#if defined(_WIN32)
#define HARNESS_API __declspec(dllexport)
#else
#define HARNESS_API __attribute__((visibility("default")))
#endif

typedef struct Harness
{
	b2WorldId world;
	int substeps;
	int bodyCount, bodyCapacity;
	b2BodyId* bodies;
	int jointCount, jointCapacity;
	b2JointId* joints;
	int contactCapacity;
	b2ContactData* contacts;
} Harness;

/* Make room for `needed` items in *array (of *capacity items). Returns 0 if out of memory. */
static int reserve(void** array, int* capacity, int needed, size_t itemSize)
{
	if (needed <= *capacity)
	{
		return 1;
	}
	int capacity2 = *capacity < 16 ? 16 : *capacity;
	while (capacity2 < needed)
	{
		capacity2 *= 2;
	}
	void* grown = realloc(*array, (size_t)capacity2 * itemSize);
	if (grown == NULL)
	{
		return 0;
	}
	*array = grown;
	*capacity = capacity2;
	return 1;
}

/* The version of the Box2D library linked in, as major * 10000 + minor * 100 + revision. */
HARNESS_API int harness_box2d_version(void)
{
	b2Version v = b2GetVersion();
	return v.major * 10000 + v.minor * 100 + v.revision;
}

/* Does nothing: peers.py times it to know what one ctypes call costs. */
HARNESS_API void harness_noop(Harness* h)
{
	(void)h;
}

/*
 * A world with gravity (gx, gy) in m/s^2, stepped with `substeps` sub-steps.
 * Sleeping is off; one worker (no task system); everything else is Box2D's default.
 */
HARNESS_API Harness* harness_create(double gx, double gy, int substeps)
{
	Harness* h = calloc(1, sizeof(Harness));
	if (h == NULL)
	{
		return NULL;
	}
	b2WorldDef def = b2DefaultWorldDef();
	def.gravity = (b2Vec2){ (float)gx, (float)gy };
	def.enableSleep = false;
	def.workerCount = 1;
	h->world = b2CreateWorld(&def);
	h->substeps = substeps;
	return h;
}

HARNESS_API void harness_destroy(Harness* h)
{
	if (h == NULL)
	{
		return;
	}
	b2DestroyWorld(h->world);
	free(h->bodies);
	free(h->joints);
	free(h->contacts);
	free(h);
}

static int add_body(Harness* h, double x, double y, int dynamic)
{
	if (!reserve((void**)&h->bodies, &h->bodyCapacity, h->bodyCount + 1, sizeof(b2BodyId)))
	{
		return -1;
	}
	b2BodyDef def = b2DefaultBodyDef();
	def.type = dynamic ? b2_dynamicBody : b2_staticBody;
	def.position = (b2Pos){ (float)x, (float)y };
	def.enableSleep = false;
	h->bodies[h->bodyCount] = b2CreateBody(h->world, &def);
	return h->bodyCount++;
}

static b2ShapeDef shape_def(double density, double friction, double restitution)
{
	b2ShapeDef def = b2DefaultShapeDef();
	def.density = (float)density;
	def.material.friction = (float)friction;
	def.material.restitution = (float)restitution;
	return def;
}

/* A box of half extents (hw, hh) m centred at (x, y); density in kg/m^2. Returns its index, -1 on failure. */
HARNESS_API int harness_add_box(Harness* h, double x, double y, double hw, double hh, double density,
								double friction, double restitution, int dynamic)
{
	int index = add_body(h, x, y, dynamic);
	if (index < 0)
	{
		return -1;
	}
	b2ShapeDef def = shape_def(density, friction, restitution);
	b2Polygon box = b2MakeBox((float)hw, (float)hh);
	b2CreatePolygonShape(h->bodies[index], &def, &box);
	return index;
}

/* A circle of radius r m centred at (x, y). Returns its index, -1 on failure. */
HARNESS_API int harness_add_circle(Harness* h, double x, double y, double r, double density, double friction,
								   double restitution, int dynamic)
{
	int index = add_body(h, x, y, dynamic);
	if (index < 0)
	{
		return -1;
	}
	b2ShapeDef def = shape_def(density, friction, restitution);
	b2Circle circle = { { 0.0f, 0.0f }, (float)r };
	b2CreateCircleShape(h->bodies[index], &def, &circle);
	return index;
}

/*
 * Pin bodies a and b together at the world point (x, y): a revolute joint with
 * Box2D's defaults (no spring, limit or motor); the joined bodies do not collide.
 * Returns the joint's index, -1 on failure.
 */
HARNESS_API int harness_add_pin(Harness* h, int a, int b, double x, double y)
{
	if (!reserve((void**)&h->joints, &h->jointCapacity, h->jointCount + 1, sizeof(b2JointId)))
	{
		return -1;
	}
	b2RevoluteJointDef def = b2DefaultRevoluteJointDef();
	b2Pos anchor = { (float)x, (float)y };
	def.base.bodyIdA = h->bodies[a];
	def.base.bodyIdB = h->bodies[b];
	def.base.localFrameA.p = b2Body_GetLocalPoint(h->bodies[a], anchor);
	def.base.localFrameB.p = b2Body_GetLocalPoint(h->bodies[b], anchor);
	def.base.collideConnected = false;
	h->joints[h->jointCount] = b2CreateRevoluteJoint(h->world, &def);
	return h->jointCount++;
}

/* Advance the world by dt seconds. */
HARNESS_API void harness_step(Harness* h, double dt)
{
	b2World_Step(h->world, (float)dt, h->substeps);
}

/* Positions (n, 2) in m and angles (n,) in rad of the n bodies listed in `index`. */
HARNESS_API void harness_read(Harness* h, const int* index, int n, double* xy, double* angle)
{
	for (int k = 0; k < n; ++k)
	{
		b2BodyId id = h->bodies[index[k]];
		b2Pos p = b2Body_GetPosition(id);
		xy[2 * k] = p.x;
		xy[2 * k + 1] = p.y;
		angle[k] = b2Rot_GetAngle(b2Body_GetRotation(id));
	}
}

/* Linear velocities (n, 2) in m/s of the n bodies listed in `index`. */
HARNESS_API void harness_velocities(Harness* h, const int* index, int n, double* v)
{
	for (int k = 0; k < n; ++k)
	{
		b2Vec2 u = b2Body_GetLinearVelocity(h->bodies[index[k]]);
		v[2 * k] = u.x;
		v[2 * k + 1] = u.y;
	}
}

/*
 * Manifold points of the touching contacts of the last step (each contact once),
 * and in *deepest the largest overlap among them (m, >= 0: minus the most negative
 * separation). Returns -1 if the contact buffer could not be grown.
 */
HARNESS_API int harness_contacts(Harness* h, double* deepest)
{
	int points = 0;
	float worst = 0.0f;
	for (int k = 0; k < h->bodyCount; ++k)
	{
		b2BodyId id = h->bodies[k];
		int capacity = b2Body_GetContactCapacity(id);
		if (!reserve((void**)&h->contacts, &h->contactCapacity, capacity, sizeof(b2ContactData)))
		{
			return -1;
		}
		int count = b2Body_GetContactData(id, h->contacts, capacity);
		for (int c = 0; c < count; ++c)
		{
			b2BodyId owner = b2Shape_GetBody(h->contacts[c].shapeIdA);
			if (B2_ID_EQUALS(owner, id) == false)
			{
				continue; /* the contact is listed on both bodies: count it on body A's list only */
			}
			const b2Manifold* m = &h->contacts[c].manifold;
			for (int p = 0; p < m->pointCount; ++p)
			{
				points += 1;
				if (-m->points[p].separation > worst)
				{
					worst = -m->points[p].separation;
				}
			}
		}
	}
	*deepest = worst;
	return points;
}

/* The harness index of body `id`, -1 if it is not one of the harness's bodies. */
static int body_index(const Harness* h, b2BodyId id)
{
	for (int k = 0; k < h->bodyCount; ++k)
	{
		if (B2_ID_EQUALS(h->bodies[k], id))
		{
			return k;
		}
	}
	return -1;
}

/* Contact recycling: Box2D v3 keeps a manifold's points while the two bodies move less than
   `distance` m relative to each other (0 turns it off). */
HARNESS_API void harness_set_recycle_distance(Harness* h, double distance)
{
	b2World_SetContactRecycleDistance(h->world, (float)distance);
}

/*
 * Every point of the touching contacts of the last step (each contact once), for comparing
 * with phys2d point by point. For point i: pair[2i], pair[2i+1] are the harness indices of
 * bodies A and B; data[10i ...] holds anchorA (x, y) and anchorB (x, y) in m (the lever arms
 * from each body's centre of mass the solver used), the separation (m), the normal impulse of
 * the last sub-step, the friction impulse (N s), the normal impulse over the whole step
 * (totalNormalImpulse, N s), and the manifold's normal (x, y). Writes at most `capacity`
 * points; returns how many there are (more than capacity: call again with room), or -1 if
 * the contact buffer could not be grown.
 */
HARNESS_API int harness_manifold_points(Harness* h, int capacity, int* pair, double* data)
{
	int points = 0;
	for (int k = 0; k < h->bodyCount; ++k)
	{
		b2BodyId id = h->bodies[k];
		int room = b2Body_GetContactCapacity(id);
		if (!reserve((void**)&h->contacts, &h->contactCapacity, room, sizeof(b2ContactData)))
		{
			return -1;
		}
		int count = b2Body_GetContactData(id, h->contacts, room);
		for (int c = 0; c < count; ++c)
		{
			b2BodyId a = b2Shape_GetBody(h->contacts[c].shapeIdA);
			if (B2_ID_EQUALS(a, id) == false)
			{
				continue; /* listed on both bodies: take it from body A's list only */
			}
			int b = body_index(h, b2Shape_GetBody(h->contacts[c].shapeIdB));
			const b2Manifold* m = &h->contacts[c].manifold;
			for (int p = 0; p < m->pointCount; ++p, ++points)
			{
				if (points >= capacity)
				{
					continue;
				}
				const b2ManifoldPoint* mp = m->points + p;
				pair[2 * points] = k;
				pair[2 * points + 1] = b;
				double* out = data + 10 * points;
				out[0] = mp->anchorA.x;
				out[1] = mp->anchorA.y;
				out[2] = mp->anchorB.x;
				out[3] = mp->anchorB.y;
				out[4] = mp->separation;
				out[5] = mp->normalImpulse;
				out[6] = mp->tangentImpulse;
				out[7] = mp->totalNormalImpulse;
				out[8] = m->normal.x;
				out[9] = m->normal.y;
			}
		}
	}
	return points;
}

/* For each joint, the distance (m) between its two anchor points now. */
HARNESS_API void harness_joint_gaps(Harness* h, double* gap)
{
	for (int k = 0; k < h->jointCount; ++k)
	{
		b2JointId id = h->joints[k];
		b2Pos pa = b2Body_GetWorldPoint(b2Joint_GetBodyA(id), b2Joint_GetLocalFrameA(id).p);
		b2Pos pb = b2Body_GetWorldPoint(b2Joint_GetBodyB(id), b2Joint_GetLocalFrameB(id).p);
		gap[k] = hypot((double)pb.x - (double)pa.x, (double)pb.y - (double)pa.y);
	}
}
