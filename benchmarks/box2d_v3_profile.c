// Box2D v3's own stage times (b2Profile) on its benchmark scenes, beside phys2d's from
// benchmarks/perf_kernels.py: where each engine spends a step.
//
// Built against the Box2D v3 tree that benchmarks/scale.py builds (its static library and its
// shared/benchmarks.c), for example:
//
//   B=benchmarks/build/box2d-v3/box2d-v3-*            # after a scale.py run with --box2d-v3 SRC
//   cc -O2 -DNDEBUG -std=gnu17 -I SRC/include -I SRC/shared benchmarks/box2d_v3_profile.c
//      SRC/shared/*.c $B/cmake/src/libbox2d.a -lm -pthread -o /tmp/box2d_v3_profile   (one line)
//   /tmp/box2d_v3_profile large 30 300
//
// Arguments: the scene (large: CreateLargePyramid, many: CreateManyPyramids), the steps before
// timing, the timed steps. One worker, 4 sub-steps, steps of 1/60 s, as scale.py's box2d-v3-1w.
// Prints each b2Profile field's mean over the timed steps, in microseconds.

#include "benchmarks.h"
#include "box2d/box2d.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char* FIELDS[] = {
	"step",			  "pairs",		   "collide",		  "solve",			"solverSetup",		"constraints",
	"prepareConstraints", "integrateVelocities", "warmStart",	  "solveImpulses",	"integratePositions", "relaxImpulses",
	"applyRestitution",	  "storeImpulses",		 "splitIslands",  "transforms",		"sensorHits",		"jointEvents",
	"hitEvents",		  "refit",				 "bullets",		  "sleepIslands",	"sensors",
};

int main( int argc, char** argv )
{
	const char* scene = argc > 1 ? argv[1] : "large";
	int settle = argc > 2 ? atoi( argv[2] ) : 30;
	int steps = argc > 3 ? atoi( argv[3] ) : 300;
	if ( steps < 1 )
	{
		fprintf( stderr, "steps must be at least 1\n" );
		return 2;
	}

	b2WorldDef def = b2DefaultWorldDef();
	def.workerCount = 1;
	b2WorldId world = b2CreateWorld( &def );
	if ( strcmp( scene, "many" ) == 0 )
	{
		CreateManyPyramids( world );
	}
	else
	{
		CreateLargePyramid( world );
	}

	for ( int i = 0; i < settle; ++i )
	{
		b2World_Step( world, 1.0f / 60.0f, 4 );
	}

	// the profile is a struct of floats (ms), one per stage: summed field by field
	enum
	{
		N = sizeof( b2Profile ) / sizeof( float )
	};
	double sum[N] = { 0 };
	for ( int i = 0; i < steps; ++i )
	{
		b2World_Step( world, 1.0f / 60.0f, 4 );
		b2Profile p = b2World_GetProfile( world );
		float f[N];
		memcpy( f, &p, sizeof f );
		for ( int k = 0; k < N; ++k )
		{
			sum[k] += f[k];
		}
	}

	int named = (int)( sizeof FIELDS / sizeof FIELDS[0] );
	for ( int k = 0; k < N; ++k )
	{
		printf( "%-20s %8.0f us\n", k < named ? FIELDS[k] : "?", sum[k] / steps * 1000.0 );
	}
	b2DestroyWorld( world );
	return 0;
}
