/* Times fts_step of the controller in fts_controller.h: argv[1] steps over
 * a 4096-sample sine reference, measurement 0.01 below it. Prints the
 * nanoseconds per step (and a checksum that keeps the loop alive).
 * Built by benches/c_runtime.rs with gcc -O2 -ffp-contract=off. */
#include "fts_controller.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static fts_controller ctl;
static double refs[4096];

static double now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
    long i, n = argc > 1 ? atol(argv[1]) : 10000000L;
    double acc = 0.0, t0, t1;
    for (i = 0; i < 4096; ++i) {
        refs[i] = 5.0 + 4.0 * sin((double)i * 0.03);
    }
    if (fts_controller_init(&ctl, NULL) != FTS_OK) {
        return 2;
    }
    for (i = 0; i < 100000; ++i) {
        acc += fts_step(&ctl, refs[i & 4095], refs[i & 4095] - 0.01);
    }
    t0 = now_ns();
    for (i = 0; i < n; ++i) {
        acc += fts_step(&ctl, refs[i & 4095], refs[i & 4095] - 0.01);
    }
    t1 = now_ns();
    printf("%.3f %g\n", (t1 - t0) / (double)n, acc);
    return 0;
}
