/* fts_loop.c: an example real-time loop around the fts C runtime.
 *
 * Reads a trace CSV (a header line, then rows "r,y": the reference r(k) and
 * the measurement y(k)), steps the controller that `fts emit --format c`
 * wrote into fts_controller.h once per row, and writes the signals as CSV
 * "k,r_f,c,u_ff,u" (%.17g: every double exactly): the filtered reference,
 * the learning correction added to it (repetitive output plus learned
 * feedforward; 0 without those blocks), the hysteresis feedforward and the
 * command. On hardware, y(k) comes from the ADC and u(k) goes to the DAC at
 * each timer tick; the controller needs the reference FTS_PREVIEW samples
 * ahead, which a machining trajectory provides (beyond its end the last
 * value is held, as in fts simulate). A learned feedforward table (fts ilc)
 * is played from the first row, one sample per step, 0 past its end.
 *
 *     fts emit ... --format c -o ctl/
 *     cc -std=c99 -O2 -ffp-contract=off -Ictl examples/c/fts_loop.c ctl/fts_runtime.c -lm -o fts_loop
 *     ./fts_loop trace.csv commands.csv
 *
 * The controller state lives in one static fts_controller: no malloc, and
 * the only memory besides it is the look-ahead ring below (and the table
 * player, three words pointing into the header's FTS_FF_TABLE). */
#include "fts_controller.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RING 4096 /* most samples of look-ahead this example buffers */

typedef struct {
    double r;
    double y;
} row;

/* Next "r,y" data row; 0 at the end of the file, -1 on a malformed line. */
static int read_row(FILE *in, row *out, long *line)
{
    char text[512];
    while (fgets(text, sizeof text, in) != NULL) {
        char *end;
        ++*line;
        if (*line == 1 && strpbrk(text, "0123456789") == NULL) {
            continue; /* the header */
        }
        out->r = strtod(text, &end);
        if (end == text || *end != ',') {
            return -1;
        }
        out->y = strtod(end + 1, &end);
        if (*end != '\n' && *end != '\r' && *end != '\0') {
            return -1;
        }
        return 1;
    }
    return 0;
}

static fts_controller controller; /* about 155 KB: static storage, not the stack */
static row ring[RING];

/* The learned feedforward f(k), when fts_controller.h has a table. */
#if FTS_HAS_FEEDFORWARD_TABLE
static fts_table table;

static fts_status learned_init(const char **field)
{
    return fts_controller_table_init(&table, field);
}

static double learned_next(void)
{
    return fts_table_next(&table);
}
#else
static fts_status learned_init(const char **field)
{
    (void)field;
    return FTS_OK;
}

static double learned_next(void)
{
    return 0.0;
}
#endif

int main(int argc, char **argv)
{
    FILE *in, *out;
    const char *field = NULL;
    size_t preview, head = 0, count = 0, k;
    long line = 0;
    int status = 1, eof = 0;
    double last_r = 0.0;
    fts_status s;

    if (argc != 3) {
        fprintf(stderr, "usage: %s trace.csv commands.csv\n", argv[0]);
        return 2;
    }
    s = fts_controller_init(&controller, &field);
    if (s == FTS_OK) {
        s = learned_init(&field);
    }
    if (s != FTS_OK) {
        fprintf(stderr, "fts_loop: error: fts_controller.h field %s: %s\n", field,
                fts_status_text(s));
        return 2;
    }
    preview = fts_preview(&controller);
    if (preview + 1 > RING) {
        fprintf(stderr, "fts_loop: error: preview %lu beyond this example's buffer %d\n",
                (unsigned long)preview, RING);
        return 2;
    }
    in = fopen(argv[1], "r");
    if (in == NULL) {
        fprintf(stderr, "fts_loop: error: %s: cannot open\n", argv[1]);
        return 2;
    }
    out = fopen(argv[2], "w");
    if (out == NULL) {
        fprintf(stderr, "fts_loop: error: %s: cannot create\n", argv[2]);
        fclose(in);
        return 1;
    }
    fprintf(out, "k,r_f,c,u_ff,u\n");
    for (k = 0;; ++k) {
        double rf, c, uff, u, ahead;
        /* Keep rows k .. k + preview buffered (fewer at the end of the file). */
        while (!eof && count < preview + 1) {
            int got = read_row(in, &ring[(head + count) % RING], &line);
            if (got < 0) {
                fprintf(stderr, "fts_loop: error: %s line %ld: expected \"r,y\"\n", argv[1],
                        line);
                status = 2;
                goto done;
            }
            if (got == 0) {
                eof = 1;
            } else {
                last_r = ring[(head + count) % RING].r;
                ++count;
            }
        }
        if (count == 0) {
            break;
        }
        ahead = count > preview ? ring[(head + preview) % RING].r : last_r;
        u = fts_step_signals(&controller, ahead, ring[head].y, learned_next(), &rf, &c, &uff);
        fprintf(out, "%lu,%.17g,%.17g,%.17g,%.17g\n", (unsigned long)k, rf, c, uff, u);
        head = (head + 1) % RING;
        --count;
    }
    status = 0;
done:
    fclose(in);
    if (fclose(out) != 0) {
        fprintf(stderr, "fts_loop: error: %s: cannot write\n", argv[2]);
        status = 1;
    }
    return status;
}
