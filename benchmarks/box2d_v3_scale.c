/*
 * Box2D v3 on its own benchmark scenes, with 1 or more workers, for benchmarks/scale.py.
 *
 * phys2d's own code (not Box2D's): it calls Box2D v3's public API and the scene builders of
 * Box2D's shared/benchmarks.c (CreateLargePyramid, CreateManyPyramids), compiled in beside it
 * by scale.py (with NDEBUG, so they build their full sizes). Loaded through ctypes.
 *
 * Workers: Box2D runs its tasks through the enqueue/finish callbacks of b2WorldDef. This file's
 * task system is the simplest that is correct: every enqueued task runs on a thread of its own,
 * started by the enqueue and joined by the finish (Box2D's solver tasks wait for each other, so
 * they must run at the same time, never one after another). A thread start costs some
 * microseconds, a few times per step. With one worker Box2D runs everything on the caller's
 * thread and never calls them.
 *
 * Box2D before 3.2 gave each task a range of items; compile with -DSCALE_RANGE_TASKS for those.
 */

#include "benchmarks.h"

#include "box2d/box2d.h"

#include <pthread.h>
#include <stdlib.h>

#if defined(_WIN32)
#define SCALE_API __declspec(dllexport)
#else
#define SCALE_API __attribute__((visibility("default")))
#endif

#define SCALE_MAX_THREADS 64

typedef struct ScaleTask ScaleTask;

typedef struct RangePiece
{
	ScaleTask* task;
	int start, end, worker;
} RangePiece;

struct ScaleTask
{
	pthread_t threads[SCALE_MAX_THREADS];
	int threadCount;
	b2TaskCallback* callback;
	void* context;
	RangePiece pieces[SCALE_MAX_THREADS]; /* the ranges of a pre-3.2 task */
};

typedef struct ScaleWorld
{
	b2WorldId world;
	int workers;
	int substeps;
} ScaleWorld;

#ifdef SCALE_RANGE_TASKS
static void* run_range(void* arg)
{
	RangePiece* p = arg;
	p->task->callback(p->start, p->end, (uint32_t)p->worker, p->task->context);
	return NULL;
}

/* Split the items into one range per worker, each on a thread of its own with its worker index. */
static void* enqueue(b2TaskCallback* callback, int itemCount, int minRange, void* context, void* user)
{
	ScaleWorld* s = user;
	int pieces = s->workers;
	if (minRange > 0 && itemCount / minRange < pieces)
	{
		pieces = itemCount / minRange > 1 ? itemCount / minRange : 1;
	}
	ScaleTask* t = pieces > 1 ? calloc(1, sizeof(ScaleTask)) : NULL;
	if (t == NULL)
	{
		callback(0, itemCount, 0, context);
		return NULL;
	}
	t->callback = callback;
	t->context = context;
	for (int i = 0; i < pieces; ++i)
	{
		RangePiece* p = t->pieces + i;
		p->task = t;
		p->start = (int)((long long)itemCount * i / pieces);
		p->end = (int)((long long)itemCount * (i + 1) / pieces);
		p->worker = i;
		if (pthread_create(&t->threads[t->threadCount], NULL, run_range, p) == 0)
		{
			t->threadCount += 1;
		}
		else
		{
			run_range(p); /* no thread: run it here */
		}
	}
	return t;
}
#else
static void* run_task(void* arg)
{
	ScaleTask* t = arg;
	t->callback(t->context);
	return NULL;
}

/* Run the task on a thread of its own. */
static void* enqueue(b2TaskCallback* callback, void* context, void* user)
{
	(void)user;
	ScaleTask* t = calloc(1, sizeof(ScaleTask));
	if (t == NULL)
	{
		callback(context);
		return NULL;
	}
	t->callback = callback;
	t->context = context;
	t->threadCount = 1;
	if (pthread_create(&t->threads[0], NULL, run_task, t) != 0)
	{
		free(t);
		callback(context);
		return NULL;
	}
	return t;
}
#endif

/* Wait for the task's threads, then free it. */
static void finish(void* userTask, void* user)
{
	(void)user;
	ScaleTask* t = userTask;
	for (int i = 0; i < t->threadCount; ++i)
	{
		pthread_join(t->threads[i], NULL);
	}
	free(t);
}

/*
 * A world of Box2D's benchmark scene `scene` (0: CreateLargePyramid, 1: CreateManyPyramids), gravity
 * (0, -10) m/s^2 (Box2D's default), stepped with `substeps` sub-steps on `workers` workers.
 */
SCALE_API ScaleWorld* scale_create(int scene, int workers, int substeps)
{
	if (workers < 1 || workers > SCALE_MAX_THREADS)
	{
		return NULL;
	}
	ScaleWorld* s = calloc(1, sizeof(ScaleWorld));
	if (s == NULL)
	{
		return NULL;
	}
	s->workers = workers;
	s->substeps = substeps;
	b2WorldDef def = b2DefaultWorldDef();
	def.workerCount = workers;
	if (workers > 1)
	{
		def.enqueueTask = enqueue;
		def.finishTask = finish;
		def.userTaskContext = s;
	}
	s->world = b2CreateWorld(&def);
	if (scene == 0)
	{
		CreateLargePyramid(s->world);
	}
	else
	{
		CreateManyPyramids(s->world);
	}
	return s;
}

SCALE_API void scale_step(ScaleWorld* s, double dt)
{
	b2World_Step(s->world, (float)dt, s->substeps);
}

SCALE_API int scale_body_count(ScaleWorld* s)
{
	return b2World_GetCounters(s->world).bodyCount;
}

/* Contacts in the world now (Box2D's counter: pairs whose fat bounding boxes overlap, touching or not). */
SCALE_API int scale_contact_pairs(ScaleWorld* s)
{
	return b2World_GetCounters(s->world).contactCount;
}

SCALE_API void scale_destroy(ScaleWorld* s)
{
	if (s == NULL)
	{
		return;
	}
	b2DestroyWorld(s->world);
	free(s);
}
