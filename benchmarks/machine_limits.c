/* This machine's limits for benchmarks/floor.py: peak float64 arithmetic and memory bandwidth.

   Built and run by floor.py (gcc -O2 -mavx2, no -mfma, no -ffast-math: the soft step's own
   arithmetic, a multiply and an add rounded apart). Prints one JSON object:

   clock_hz      the core's clock while busy: a chain of dependent integer adds (one a cycle)
   packed_flops  packed (4 x float64, ymm) adds and multiplies, 6 independent chains of each in
                 flight (enough to fill two add and two multiply pipes of latency 3, or two
                 shared pipes of latency 4), per second: what a vectorised loop could reach at
                 best (no FMA)
   scalar_flops  the same with scalar float64 (a sweep's instructions, one value a register)
   packed_divs   packed float64 divisions per second (8 independent chains), in float64
                 values (4 a vdivpd); scalar_divs the same with scalar divisions
   bandwidth     per working-set size (bytes): read (a sum over the array, 8 ymm loads in
                 flight), write (stores of a ymm register) and copy (a load and a store of each
                 ymm, counted both ways: 2 bytes moved per byte copied), in bytes per second

   Every measure is short (a few milliseconds, less than the scheduler's time slice) and the best
   of REPEATS is kept: on a shared host the slower runs are other programs' doing (a run that
   shares its core with another busy process gets a fraction of it).

   The chains are written out as named variables: gcc 12 -O2 keeps an array of them in memory
   (the assembly of this file's first version), where each update waits for a store and a load.
   The copy loop is kept a loop (gcc -O2 would call memcpy, which switches to non-temporal stores
   on large arrays; a kernel's stores do not). */
#include <immintrin.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define REPEATS 30

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static volatile double sink;

static double sum4(__m256d v) {
    double out[4];
    _mm256_storeu_pd(out, v);
    return out[0] + out[1] + out[2] + out[3];
}

/* 100 dependent integer adds a loop (x86-64: one a cycle): cycles per second */
static double clock_hz(long reps) {
#define ADD10 "add $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\t" \
              "add $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\t"
    long x = 0;
    double t0 = now();
    for (long r = 0; r < reps; r++)
        __asm__ volatile(ADD10 ADD10 ADD10 ADD10 ADD10 ADD10 ADD10 ADD10 ADD10 ADD10 : "+r"(x));
    double t = now() - t0;
    sink = (double)x;
    return reps * 100.0 / t;
}

/* 6 chains of packed adds and 6 of packed multiplies: flops per second */
static double packed_flops(long reps) {
    const __m256d add = _mm256_set1_pd(1e-9), mul = _mm256_set1_pd(1.0 - 1e-12);
    __m256d a0 = _mm256_set1_pd(0.0), a1 = _mm256_set1_pd(1.0), a2 = _mm256_set1_pd(2.0);
    __m256d a3 = _mm256_set1_pd(3.0), a4 = _mm256_set1_pd(4.0), a5 = _mm256_set1_pd(5.0);
    __m256d m0 = _mm256_set1_pd(1.0), m1 = _mm256_set1_pd(2.0), m2 = _mm256_set1_pd(3.0);
    __m256d m3 = _mm256_set1_pd(4.0), m4 = _mm256_set1_pd(5.0), m5 = _mm256_set1_pd(6.0);
    double t0 = now();
    for (long r = 0; r < reps; r++) {
        a0 = _mm256_add_pd(a0, add);
        m0 = _mm256_mul_pd(m0, mul);
        a1 = _mm256_add_pd(a1, add);
        m1 = _mm256_mul_pd(m1, mul);
        a2 = _mm256_add_pd(a2, add);
        m2 = _mm256_mul_pd(m2, mul);
        a3 = _mm256_add_pd(a3, add);
        m3 = _mm256_mul_pd(m3, mul);
        a4 = _mm256_add_pd(a4, add);
        m4 = _mm256_mul_pd(m4, mul);
        a5 = _mm256_add_pd(a5, add);
        m5 = _mm256_mul_pd(m5, mul);
    }
    double t = now() - t0;
    __m256d s = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(a0, a1), _mm256_add_pd(a2, a3)), _mm256_add_pd(a4, a5));
    s = _mm256_add_pd(s, _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(m0, m1), _mm256_add_pd(m2, m3)),
                                       _mm256_add_pd(m4, m5)));
    sink = sum4(s);
    return reps * 12.0 * 4.0 / t;
}

/* the same with scalar doubles (no SLP vectorising: gcc would otherwise pack pairs of chains
   into one vector instruction) */
__attribute__((optimize("no-tree-slp-vectorize"))) static double scalar_flops(long reps) {
    double a0 = 0.0, a1 = 1.0, a2 = 2.0, a3 = 3.0, a4 = 4.0, a5 = 5.0;
    double m0 = 1.0, m1 = 2.0, m2 = 3.0, m3 = 4.0, m4 = 5.0, m5 = 6.0;
    const double add = 1e-9, mul = 1.0 - 1e-12;
    double t0 = now();
    for (long r = 0; r < reps; r++) {
        a0 += add;
        m0 *= mul;
        a1 += add;
        m1 *= mul;
        a2 += add;
        m2 *= mul;
        a3 += add;
        m3 *= mul;
        a4 += add;
        m4 *= mul;
        a5 += add;
        m5 *= mul;
    }
    double t = now() - t0;
    sink = a0 + a1 + a2 + a3 + a4 + a5 + m0 + m1 + m2 + m3 + m4 + m5;
    return reps * 12.0 / t;
}

/* 8 chains of packed divisions x = x / c: float64 divisions per second */
static double packed_divs(long reps) {
    const __m256d c = _mm256_set1_pd(1.0 + 1e-12);
    __m256d d0 = _mm256_set1_pd(1.0), d1 = _mm256_set1_pd(2.0), d2 = _mm256_set1_pd(3.0);
    __m256d d3 = _mm256_set1_pd(4.0), d4 = _mm256_set1_pd(5.0), d5 = _mm256_set1_pd(6.0);
    __m256d d6 = _mm256_set1_pd(7.0), d7 = _mm256_set1_pd(8.0);
    double t0 = now();
    for (long r = 0; r < reps; r++) {
        d0 = _mm256_div_pd(d0, c);
        d1 = _mm256_div_pd(d1, c);
        d2 = _mm256_div_pd(d2, c);
        d3 = _mm256_div_pd(d3, c);
        d4 = _mm256_div_pd(d4, c);
        d5 = _mm256_div_pd(d5, c);
        d6 = _mm256_div_pd(d6, c);
        d7 = _mm256_div_pd(d7, c);
    }
    double t = now() - t0;
    __m256d s = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(d0, d1), _mm256_add_pd(d2, d3)),
                              _mm256_add_pd(_mm256_add_pd(d4, d5), _mm256_add_pd(d6, d7)));
    sink = sum4(s);
    return reps * 8.0 * 4.0 / t;
}

__attribute__((optimize("no-tree-slp-vectorize"))) static double scalar_divs(long reps) {
    double d0 = 1.0, d1 = 2.0, d2 = 3.0, d3 = 4.0, d4 = 5.0, d5 = 6.0, d6 = 7.0, d7 = 8.0;
    const double c = 1.0 + 1e-12;
    double t0 = now();
    for (long r = 0; r < reps; r++) {
        d0 /= c;
        d1 /= c;
        d2 /= c;
        d3 /= c;
        d4 /= c;
        d5 /= c;
        d6 /= c;
        d7 /= c;
    }
    double t = now() - t0;
    sink = d0 + d1 + d2 + d3 + d4 + d5 + d6 + d7;
    return reps * 8.0 / t;
}

static double read_pass(const double *x, size_t n) {
    __m256d s0 = _mm256_setzero_pd(), s1 = s0, s2 = s0, s3 = s0, s4 = s0, s5 = s0, s6 = s0, s7 = s0;
    for (size_t i = 0; i + 32 <= n; i += 32) {
        s0 = _mm256_add_pd(s0, _mm256_load_pd(x + i));
        s1 = _mm256_add_pd(s1, _mm256_load_pd(x + i + 4));
        s2 = _mm256_add_pd(s2, _mm256_load_pd(x + i + 8));
        s3 = _mm256_add_pd(s3, _mm256_load_pd(x + i + 12));
        s4 = _mm256_add_pd(s4, _mm256_load_pd(x + i + 16));
        s5 = _mm256_add_pd(s5, _mm256_load_pd(x + i + 20));
        s6 = _mm256_add_pd(s6, _mm256_load_pd(x + i + 24));
        s7 = _mm256_add_pd(s7, _mm256_load_pd(x + i + 28));
    }
    return sum4(_mm256_add_pd(_mm256_add_pd(_mm256_add_pd(s0, s1), _mm256_add_pd(s2, s3)),
                              _mm256_add_pd(_mm256_add_pd(s4, s5), _mm256_add_pd(s6, s7))));
}

static void write_pass(double *x, size_t n, double v) {
    __m256d w = _mm256_set1_pd(v);
    for (size_t i = 0; i + 4 <= n; i += 4) _mm256_store_pd(x + i, w);
}

__attribute__((optimize("no-tree-loop-distribute-patterns"))) static void copy_pass(double *y, const double *x,
                                                                                   size_t n) {
    for (size_t i = 0; i + 4 <= n; i += 4) _mm256_store_pd(y + i, _mm256_load_pd(x + i));
}

static double best(double a, double b) { return a > b ? a : b; }

int main(void) {
    double hz = 0.0, p = 0.0, s = 0.0, pd = 0.0, sd = 0.0;
    for (int k = 0; k < REPEATS; k++) { /* each about 2 ms at this machine's speeds */
        hz = best(hz, clock_hz(50000));
        p = best(p, packed_flops(2000000));
        s = best(s, scalar_flops(2000000));
        pd = best(pd, packed_divs(200000));
        sd = best(sd, scalar_divs(500000));
    }
    printf("{\"clock_hz\": %.6g, \"packed_flops\": %.6g, \"scalar_flops\": %.6g, \"packed_divs\": %.6g, "
           "\"scalar_divs\": %.6g, \"bandwidth\": [",
           hz, p, s, pd, sd);
    size_t sizes[] = {16 << 10, 128 << 10, 256 << 10, 1 << 20, 2 << 20, 4 << 20, 8 << 20,
                      16 << 20, 32 << 20, 64 << 20, 256 << 20};
    int n_sizes = sizeof sizes / sizeof sizes[0];
    for (int z = 0; z < n_sizes; z++) {
        size_t n = sizes[z] / 8;
        double *x = aligned_alloc(64, n * 8), *y = aligned_alloc(64, n * 8);
        for (size_t i = 0; i < n; i++) x[i] = y[i] = (double)i;
        long passes = (long)(5e7 / sizes[z]) + 1; /* ~50 MB a measure (one pass of the largest) */
        double br = 0.0, bw = 0.0, bc = 0.0;
        for (int k = 0; k < REPEATS; k++) {
            double t0 = now(), acc = 0.0;
            for (long q = 0; q < passes; q++) acc += read_pass(x, n);
            double t = now() - t0;
            sink = acc;
            br = best(br, passes * (double)sizes[z] / t);
            t0 = now();
            for (long q = 0; q < passes; q++) write_pass(y, n, (double)q);
            t = now() - t0;
            sink = y[n / 2];
            bw = best(bw, passes * (double)sizes[z] / t);
            t0 = now();
            for (long q = 0; q < passes; q++) copy_pass(y, x, n);
            t = now() - t0;
            sink = y[n / 3];
            bc = best(bc, 2.0 * passes * (double)sizes[z] / t);
        }
        printf("%s{\"bytes\": %zu, \"read\": %.6g, \"write\": %.6g, \"copy\": %.6g}", z ? ", " : "", sizes[z], br,
               bw, bc);
        free(x);
        free(y);
    }
    printf("]}\n");
    return 0;
}
