/* fts_multiaxis_loop.c: an example three-axis loop around the fts C runtime's
 * cross-coupled step (docs/contouring.md).
 *
 * Reads a trace CSV (a header line, then rows
 * "x_ref,y_ref,z_ref,t_x,t_y,t_z,x,y,z": the reference point, the unit
 * tangent of the path there and the measured positions), steps the
 * controllers that `fts emit --multiaxis K3.json --format c` wrote into
 * fts_multiaxis.h once per row, and writes "k,u_x,u_y,u_z" (%.17g: every
 * double exactly). On a machine the reference and tangent come from the
 * trajectory table (fts trajectory), the positions from the encoders, and
 * the commands go to the three drives at each timer tick.
 *
 *     fts emit --multiaxis controller-3axis.json --format c -o ctl/
 *     cc -std=c99 -O2 -ffp-contract=off -Ictl examples/c/fts_multiaxis_loop.c ctl/fts_runtime.c -o loop3
 *     ./loop3 trace.csv commands.csv
 *
 * The state lives in one static fts_multiaxis (about 15 KB): no malloc. */
#include "fts_multiaxis.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Next data row of nine numbers; 0 at the end of the file, -1 on a malformed line. */
static int read_row(FILE *in, double v[9], long *line)
{
    char text[1024];
    while (fgets(text, sizeof text, in) != NULL) {
        char *p = text, *end;
        int i;
        ++*line;
        if (*line == 1 && strpbrk(text, "0123456789") == NULL) {
            continue; /* the header */
        }
        for (i = 0; i < 9; ++i) {
            v[i] = strtod(p, &end);
            if (end == p || (i < 8 && *end != ',')) {
                return -1;
            }
            p = end + 1;
        }
        if (*end != '\n' && *end != '\r' && *end != '\0') {
            return -1;
        }
        return 1;
    }
    return 0;
}

static fts_multiaxis controller;

int main(int argc, char **argv)
{
    FILE *in, *out;
    const char *field = NULL;
    double v[9], u[3];
    long line = 0, k = 0;
    int status;
    fts_status s;
    if (argc != 3) {
        fprintf(stderr, "usage: %s trace.csv commands.csv\n", argv[0]);
        return 2;
    }
    s = fts_multiaxis_controller_init(&controller, &field);
    if (s != FTS_OK) {
        fprintf(stderr, "fts_multiaxis.h: %s: %s\n", field != NULL ? field : "?",
                fts_status_text(s));
        return 2;
    }
    in = fopen(argv[1], "r");
    if (in == NULL) {
        fprintf(stderr, "%s: cannot open\n", argv[1]);
        return 2;
    }
    out = fopen(argv[2], "w");
    if (out == NULL) {
        fprintf(stderr, "%s: cannot create\n", argv[2]);
        fclose(in);
        return 2;
    }
    fprintf(out, "k,u_x,u_y,u_z\n");
    while ((status = read_row(in, v, &line)) == 1) {
        fts_multiaxis_step(&controller, v, v + 3, v + 6, u);
        fprintf(out, "%ld,%.17g,%.17g,%.17g\n", k, u[0], u[1], u[2]);
        ++k;
    }
    fclose(in);
    fclose(out);
    if (status < 0) {
        fprintf(stderr, "%s line %ld: expected nine numbers\n", argv[1], line);
        return 2;
    }
    return 0;
}
