/* This machine's limits for benchmarks/floor.py: peak float64 arithmetic and memory bandwidth.

   Built and run by floor.py (gcc -O2 -mavx2, no -mfma, no -ffast-math: the soft step's own
   arithmetic, a multiply and an add rounded apart). Prints one JSON object:

   flops      packed (4 x float64, ymm) adds and multiplies, 8 independent chains of each in
              flight, per second: what the lanes' loops could reach at best (no FMA); and the
              same with scalar float64 (the scalar sweep's instructions)
   bandwidth  per working-set size (bytes): read (a sum over the array, 4 ymm loads in flight),
              write (stores of a ymm register) and copy (read + write, counted both ways), in
              bytes per second; each the best of several repeats

   Each measure runs long enough (~0.2 s) for the clock to settle; the best of 5 is kept, since
   on a shared host the slower runs are other programs' doing. */
#include <immintrin.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static volatile double sink;

/* adds and multiplies of 4 doubles, 8 chains of each: returns flops per second */
static double packed_flops(long reps) {
    __m256d a[8], m[8];
    const __m256d add = _mm256_set1_pd(1e-9), mul = _mm256_set1_pd(1.0 - 1e-12);
    for (int i = 0; i < 8; i++) {
        a[i] = _mm256_set1_pd(i);
        m[i] = _mm256_set1_pd(1.0 + i);
    }
    double t0 = now();
    for (long r = 0; r < reps; r++) {
        for (int i = 0; i < 8; i++) {
            a[i] = _mm256_add_pd(a[i], add);
            m[i] = _mm256_mul_pd(m[i], mul);
        }
    }
    double t = now() - t0;
    __m256d s = _mm256_setzero_pd();
    for (int i = 0; i < 8; i++) s = _mm256_add_pd(s, _mm256_add_pd(a[i], m[i]));
    double out[4];
    _mm256_storeu_pd(out, s);
    sink = out[0] + out[1] + out[2] + out[3];
    return reps * 16.0 * 4.0 / t;
}

/* the same with scalar doubles */
static double scalar_flops(long reps) {
    double a[8], m[8];
    for (int i = 0; i < 8; i++) {
        a[i] = i;
        m[i] = 1.0 + i;
    }
    double t0 = now();
    for (long r = 0; r < reps; r++) {
        for (int i = 0; i < 8; i++) {
            __asm__("" : "+x"(a[i]), "+x"(m[i])); /* keep the chains apart (no vectorising) */
            a[i] += 1e-9;
            m[i] *= 1.0 - 1e-12;
        }
    }
    double t = now() - t0;
    double s = 0.0;
    for (int i = 0; i < 8; i++) s += a[i] + m[i];
    sink = s;
    return reps * 16.0 / t;
}

static double read_pass(const double *x, size_t n) {
    __m256d s0 = _mm256_setzero_pd(), s1 = s0, s2 = s0, s3 = s0;
    for (size_t i = 0; i + 16 <= n; i += 16) {
        s0 = _mm256_add_pd(s0, _mm256_load_pd(x + i));
        s1 = _mm256_add_pd(s1, _mm256_load_pd(x + i + 4));
        s2 = _mm256_add_pd(s2, _mm256_load_pd(x + i + 8));
        s3 = _mm256_add_pd(s3, _mm256_load_pd(x + i + 12));
    }
    double out[4];
    _mm256_storeu_pd(out, _mm256_add_pd(_mm256_add_pd(s0, s1), _mm256_add_pd(s2, s3)));
    return out[0] + out[1] + out[2] + out[3];
}

static void write_pass(double *x, size_t n, double v) {
    __m256d w = _mm256_set1_pd(v);
    for (size_t i = 0; i + 4 <= n; i += 4) _mm256_store_pd(x + i, w);
}

static void copy_pass(double *y, const double *x, size_t n) {
    for (size_t i = 0; i + 4 <= n; i += 4) _mm256_store_pd(y + i, _mm256_load_pd(x + i));
}

int main(void) {
    long reps = 20000000;
    double best_p = 0.0, best_s = 0.0;
    for (int k = 0; k < 5; k++) {
        double p = packed_flops(reps), s = scalar_flops(reps);
        best_p = p > best_p ? p : best_p;
        best_s = s > best_s ? s : best_s;
    }
    printf("{\"packed_flops\": %.6g, \"scalar_flops\": %.6g, \"bandwidth\": [", best_p, best_s);
    size_t sizes[] = {16 << 10, 256 << 10, 2 << 20, 8 << 20, 32 << 20, 256 << 20};
    int n_sizes = sizeof sizes / sizeof sizes[0];
    for (int z = 0; z < n_sizes; z++) {
        size_t n = sizes[z] / 8;
        double *x = aligned_alloc(64, n * 8), *y = aligned_alloc(64, n * 8);
        for (size_t i = 0; i < n; i++) x[i] = y[i] = (double)i;
        long passes = (long)(1.5e9 / sizes[z]) + 1;
        double br = 0.0, bw = 0.0, bc = 0.0;
        for (int k = 0; k < 5; k++) {
            double t0 = now(), s = 0.0;
            for (long q = 0; q < passes; q++) s += read_pass(x, n);
            double t = now() - t0;
            sink = s;
            br = passes * (double)sizes[z] / t > br ? passes * (double)sizes[z] / t : br;
            t0 = now();
            for (long q = 0; q < passes; q++) write_pass(y, n, (double)q);
            t = now() - t0;
            sink = y[n / 2];
            bw = passes * (double)sizes[z] / t > bw ? passes * (double)sizes[z] / t : bw;
            t0 = now();
            for (long q = 0; q < passes; q++) copy_pass(y, x, n);
            t = now() - t0;
            sink = y[n / 3];
            bc = 2.0 * passes * (double)sizes[z] / t > bc ? 2.0 * passes * (double)sizes[z] / t : bc;
        }
        printf("%s{\"bytes\": %zu, \"read\": %.6g, \"write\": %.6g, \"copy\": %.6g}", z ? ", " : "", sizes[z], br, bw, bc);
        free(x);
        free(y);
    }
    printf("]}\n");
    return 0;
}
