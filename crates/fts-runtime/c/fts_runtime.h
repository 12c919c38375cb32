/* fts_runtime.h: the fts controller step in C99, the twin of the Rust crate
 * fts-runtime (crates/fts-runtime/src/lib.rs). Written by `fts emit --format c`
 * beside fts_controller.h (the coefficients); see docs/formats.md "C runtime".
 *
 * Per sample k, in signal order ([Li21] Fig. 5):
 *   r_f  = ZPETC num/den on r(k + preview)          (r_f = r without ZPETC)
 *   v    = repetitive compensator on e(k) = r(k) - x(k), r(k) the reference
 *          passed preview samples earlier           (0 without the block)
 *   c    = v + f, f the learned feedforward sample passed by the caller
 *          (an fts_table played once per step; 0 without one)
 *   r_l  = r_f + c, the loop's reference
 *   u_ff = inverse hysteresis of r_l                 (0 without the block)
 *   u    = clamp(u_ff + feedback(r_l - x), min, max) (PID, filtered PID or
 *          state space; without feedback: u_ff with a hysteresis block, else r_l)
 *
 * The repetitive compensator (Tomizuka, Tsao & Chew 1989) is the plug-in
 *   v(k) = Q(z) [ v(k - N) + gain e(k - N + lead) ],
 * Q(z) = q[0] + sum_i q[i] (z^i + z^-i) zero phase, N = period + fraction
 * samples with the fractional delay read by linear interpolation
 * z^-N ~ (1 - fraction) z^-period + fraction z^-(period + 1); its memory is
 * the ring rc_memory (FTS_MAX_PERIOD samples) inside fts_controller.
 *
 * Fixed capacity, no malloc, no globals: all state lives in the caller's
 * fts_controller. The arithmetic is the Rust step's, operation for operation;
 * compile without floating-point contraction (-ffp-contract=off; never
 * -ffast-math) and the commands are bit-identical to fts simulate's on any
 * IEEE-754 double target (the cube root is the runtime's own, not the C
 * library's). Only freestanding headers are used: no C library is needed.
 */
#ifndef FTS_RUNTIME_H
#define FTS_RUNTIME_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Capacities, the Rust crate's. Override them (identically in every
 * translation unit) to shrink fts_controller on small targets. */
#ifndef FTS_MAX_FILTER_LEN
#define FTS_MAX_FILTER_LEN 512
#endif
#ifndef FTS_MAX_OPERATORS
#define FTS_MAX_OPERATORS 64
#endif
#ifndef FTS_MAX_DEAD_ZONES
#define FTS_MAX_DEAD_ZONES 16
#endif
#ifndef FTS_MAX_SS_ORDER
#define FTS_MAX_SS_ORDER 16
#endif

#ifndef FTS_MAX_DOB_LEN
/* Longest polynomial of a DOB filter (Q or the nominal inverse). */
#define FTS_MAX_DOB_LEN 16
#endif

#ifndef FTS_MAX_DOB_DELAY
/* Longest command delay d of a DOB's nominal plant. */
#define FTS_MAX_DOB_DELAY 16
#endif

/* The repetitive compensator's memory, samples: a period of up to
 * FTS_MAX_PERIOD - h - 2 samples (h = q_len - 1). FTS_MAX_PERIOD,
 * FTS_MAX_LEAD + 1 and FTS_MAX_RC_PREVIEW + 1 are ring lengths and must be
 * powers of two no longer than FTS_MAX_PERIOD (checked when compiling
 * fts_runtime.c). The rings are 138 KB of fts_controller; a target
 * without a repetitive block may define FTS_MAX_PERIOD 1, FTS_MAX_LEAD 0 and
 * FTS_MAX_RC_PREVIEW 0 (fts_init then refuses any repetitive block). */
#ifndef FTS_MAX_PERIOD
#define FTS_MAX_PERIOD 16384
#endif
#ifndef FTS_MAX_Q_HALF
#define FTS_MAX_Q_HALF 32 /* most one-sided taps of Q, q[1] .. q[h] */
#endif
#ifndef FTS_MAX_LEAD
#define FTS_MAX_LEAD 255 /* most samples of phase lead */
#endif
#ifndef FTS_MAX_RC_PREVIEW
#define FTS_MAX_RC_PREVIEW 1023 /* most ZPETC preview the repetitive block can undo */
#endif

/* Why a specification cannot be loaded (the Rust RuntimeError). */
typedef enum fts_status {
    FTS_OK = 0,
    FTS_ERR_BAD_LENGTH = 1,      /* a list is empty or beyond its capacity */
    FTS_ERR_ORDER_TOO_HIGH = 2,  /* more states than FTS_MAX_SS_ORDER */
    FTS_ERR_LENGTH_MISMATCH = 3, /* two partner lists differ in length */
    FTS_ERR_NON_FINITE = 4,      /* NaN or infinity */
    FTS_ERR_INVALID = 5          /* den[0] = 0, unordered limits, pole or fraction
                                    outside [0, 1), period not beyond h + lead */
} fts_status;

typedef enum fts_play_form {
    FTS_PLAY_LOWER = 0,    /* F = max(x - r, min(x, F_prev))      [Li21] Eq. 3 */
    FTS_PLAY_SYMMETRIC = 1 /* F = max(x - r, min(x + r, F_prev))  [Tang17] Eq. 37-39 */
} fts_play_form;

typedef enum fts_feedback_kind {
    FTS_FEEDBACK_NONE = 0,         /* feedforward only */
    FTS_FEEDBACK_PID = 1,          /* [Li21] Eq. 5, gains per sample */
    FTS_FEEDBACK_PID_FILTERED = 2, /* the same with a filtered derivative */
    FTS_FEEDBACK_STATE_SPACE = 3,  /* v = C x + D e; x <- A x + B e */
    FTS_FEEDBACK_DOB = 4           /* state space + disturbance observer + friction ff */
} fts_feedback_kind;

/* ZPETC pre-filter: ascending powers of z^-1, den[0] != 0. */
typedef struct fts_zpetc_spec {
    size_t preview;
    const double *num;
    size_t num_len;
    const double *den;
    size_t den_len;
} fts_zpetc_spec;

/* Hysteresis compensation: the model
 *   Y(u) = offset + cbrt_gain cbrt(x) + Out[sum_i (w_i + w1_i |s|) F_i[x]] + velocity_gain s,
 * x = u - input_offset, s = (x(k) - x(k-1)) / (rate_ts rate_scale), x(-1) = 0
 * (the rate terms only with rate_weights_len != 0); Out is the identity
 * without dead zones, else sum_j g_j S_dj[.] with S_d[v] = max(v - d, 0)
 * (d != 0), S_0[v] = v. solve == 0: u_ff = Y(r_f) (an inverse model);
 * solve != 0: u_ff in [solve_min, solve_max] with Y(u_ff) = r_f (a forward
 * model, inverted per sample; saturates at the closer end when r_f is out
 * of reach). */
typedef struct fts_hysteresis_spec {
    fts_play_form form;
    const double *thresholds;
    size_t thresholds_len;
    const double *weights;
    size_t weights_len;
    double cbrt_gain;
    double offset;
    double input_offset;
    const double *dead_zone_thresholds; /* may be NULL with length 0 */
    size_t dead_zone_thresholds_len;
    const double *dead_zone_weights;
    size_t dead_zone_weights_len;
    /* The input stage of the analytic inverse of an MPI-deadzone model. */
    const double *input_dead_zone_thresholds; /* may be NULL with length 0 */
    size_t input_dead_zone_thresholds_len;
    const double *input_dead_zone_weights;
    size_t input_dead_zone_weights_len;
    const double *rate_weights; /* may be NULL with length 0: rate-independent */
    size_t rate_weights_len;
    double rate_ts;
    double rate_scale;
    double velocity_gain;
    int solve;
    double solve_min;
    double solve_max;
} fts_hysteresis_spec;

/* PID on e = r_f - x, derivative on the measurement x:
 *   d(k) = derivative_pole d(k-1) + kd (x(k) - x(k-1))   (pole 0 for FTS_FEEDBACK_PID)
 *   u = clamp(u_ff + kp e + I(k-1) + ki e - d(k)); I keeps I(k-1) + ki e unless
 *   the command is saturated with e pushing further out. */
typedef struct fts_pid_spec {
    double kp;
    double ki;
    double kd;
    double derivative_pole; /* FTS_FEEDBACK_PID_FILTERED only, in [0, 1) */
    double output_min;
    double output_max;
} fts_pid_spec;

/* State-space controller, SISO, e in, v out: a is n x n row-major, b n x 1,
 * c 1 x n. Limits may be -fts_infinity() / fts_infinity() (no limit). */
typedef struct fts_ss_spec {
    size_t n;
    const double *a;
    const double *b;
    const double *c;
    double d;
    double output_min;
    double output_max;
    int conditional_update; /* hold x while saturated and C (x+ - x) points further out */
} fts_ss_spec;

/* Disturbance observer around a state-space controller K (ss, on e = r - x),
 * with friction feedforward ([Karagoz18]; Ohnishi; Umeno & Hori); Rust DobSpec:
 *   A[x](k) = sum_j inverse_num[j] (Delta^j x)(k), Delta^j x(k) = Delta^(j-1) x(k) - Delta^(j-1) x(k-1)
 *             (inverse_num in ascending powers of the backward difference 1 - z^-1)
 *   w = (1/inverse_den)[A[x]](k) - (u - u_f)(k - delay), u_f the friction term below
 *   d_hat = (q_num/q_den)[w](k)
 *   v = (r(k) - r(k-1))/ts (0 at the first sample)
 *   u_f = coulomb v/(|v| + smoothing) + viscous v
 *   u = K step (ss_step) with feedforward (u_ff - d_hat) + u_f
 * u(k - delay) is the command applied (fts_multiaxis_step stores the sum with
 * the coupling's command). Filters ascending z^-1, den[0] != 0, at most
 * FTS_MAX_DOB_LEN coefficients; 1 <= delay <= FTS_MAX_DOB_DELAY; smoothing, ts > 0. */
typedef struct fts_dob_spec {
    const double *q_num;
    size_t q_num_len;
    const double *q_den;
    size_t q_den_len;
    const double *inverse_num;
    size_t inverse_num_len;
    const double *inverse_den;
    size_t inverse_den_len;
    size_t delay;
    double coulomb;
    double viscous;
    double smoothing;
    double ts;
} fts_dob_spec;

/* Plug-in repetitive compensator on the tracking error e = r - x (r the
 * reference undelayed by the ZPETC preview), its output added to r_f:
 *   v(k) = sum_{i=-h..h} q[|i|] D(k - i - period) with
 *   D(j) = (1 - fraction) d(j) + fraction d(j - 1), d(j) = v(j) + gain e(j + lead),
 * every signal 0 before the first step. Needs period > h + lead (h = q_len - 1),
 * period + h + 2 <= FTS_MAX_PERIOD, q_len <= FTS_MAX_Q_HALF + 1,
 * lead <= FTS_MAX_LEAD, fraction in [0, 1) and the ZPETC preview at most
 * FTS_MAX_RC_PREVIEW. */
typedef struct fts_repetitive_spec {
    size_t period;   /* whole samples of the period, N0 */
    double fraction; /* fractional part of the period, in [0, 1) */
    const double *q; /* zero-phase low-pass taps q[0], q[1] .. q[h] */
    size_t q_len;
    size_t lead;     /* phase lead m, samples */
    double gain;     /* learning gain k_r */
} fts_repetitive_spec;

/* A whole controller; NULL blocks are absent. */
typedef struct fts_spec {
    const fts_zpetc_spec *zpetc;
    const fts_hysteresis_spec *hysteresis;
    fts_feedback_kind feedback;
    fts_pid_spec pid;   /* FTS_FEEDBACK_PID and FTS_FEEDBACK_PID_FILTERED */
    fts_ss_spec ss;     /* FTS_FEEDBACK_STATE_SPACE */
    fts_dob_spec dob;   /* FTS_FEEDBACK_DOB (with ss, its outer controller) */
    const fts_repetitive_spec *repetitive; /* NULL: no repetitive compensator */
} fts_spec;

/* One feedback controller with its state: the PID (gains, integrator,
 * filtered derivative) or the state-space block (matrices and states). */
typedef struct fts_feedback {
    fts_feedback_kind kind;
    fts_pid_spec pid;
    double integral;
    double derivative;
    double previous_measurement;
    int started;

    size_t nx;
    double ss_a[FTS_MAX_SS_ORDER][FTS_MAX_SS_ORDER];
    double ss_b[FTS_MAX_SS_ORDER];
    double ss_c[FTS_MAX_SS_ORDER];
    double ss_d;
    double ss_min;
    double ss_max;
    int conditional_update;
    double x[FTS_MAX_SS_ORDER];

    size_t dob_q_order;
    double dob_qb[FTS_MAX_DOB_LEN];
    double dob_qa[FTS_MAX_DOB_LEN];
    double dob_qs[FTS_MAX_DOB_LEN];
    size_t dob_diff_len;
    double dob_diff[FTS_MAX_DOB_LEN];
    double dob_diffs[FTS_MAX_DOB_LEN];
    size_t dob_inv_order;
    double dob_ib[FTS_MAX_DOB_LEN];
    double dob_ia[FTS_MAX_DOB_LEN];
    double dob_is[FTS_MAX_DOB_LEN];
    size_t dob_delay;
    double dob_commands[FTS_MAX_DOB_DELAY];
    size_t dob_head;
    double dob_last_friction;
    double dob_coulomb;
    double dob_viscous;
    double dob_smoothing;
    double dob_rate;
    double dob_previous_reference;
    int dob_started;
} fts_feedback;

/* One feedback controller's coefficients: pid for FTS_FEEDBACK_PID and
 * FTS_FEEDBACK_PID_FILTERED, ss for FTS_FEEDBACK_STATE_SPACE, ss and dob
 * for FTS_FEEDBACK_DOB. */
typedef struct fts_feedback_spec {
    fts_feedback_kind kind;
    fts_pid_spec pid;
    fts_ss_spec ss;
    fts_dob_spec dob;
} fts_feedback_spec;

/* The cross-coupled multi-axis step (docs/contouring.md; the Rust
 * CrossCoupledStep): three axis controllers and, when coupled, one copy per
 * axis of the cross-coupling controller. Per sample, r the reference point,
 * t the unit tangent of the path at r, y the measured positions:
 *   e = r - y, eps = e - (e . t) t                    (Yeh & Hsu's estimate)
 *   u_i = K_i[r_i, y_i] + K_cc[0, -eps_i]
 * each controller clamped to its own limits; the coupling sees the reference
 * 0 and the measurement -eps_i, so its error is eps_i and a PID's derivative
 * acts on eps_i. About 15 KB with the default FTS_MAX_SS_ORDER. */
typedef struct fts_multiaxis {
    fts_feedback axes[3];
    int coupled;
    fts_feedback cross[3];
} fts_multiaxis;

/* A loaded controller with its state: the caller owns it (static storage;
 * it is about 155 KB with the default capacities, 138 KB of which are the
 * repetitive compensator's rings: see FTS_MAX_PERIOD). */
typedef struct fts_controller {
    int has_zpetc;
    size_t preview;
    size_t order;
    double zb[FTS_MAX_FILTER_LEN];
    double za[FTS_MAX_FILTER_LEN];
    double zstate[FTS_MAX_FILTER_LEN];

    int has_hysteresis;
    fts_play_form form;
    size_t n_operators;
    double thresholds[FTS_MAX_OPERATORS];
    double weights[FTS_MAX_OPERATORS];
    double play[FTS_MAX_OPERATORS];
    double cbrt_gain;
    double offset;
    double input_offset;
    size_t n_dead_zones;
    double dz_thresholds[FTS_MAX_DEAD_ZONES];
    double dz_weights[FTS_MAX_DEAD_ZONES];
    size_t n_input_dead_zones;
    double idz_thresholds[FTS_MAX_DEAD_ZONES];
    double idz_weights[FTS_MAX_DEAD_ZONES];
    int has_rate;
    double rate_weights[FTS_MAX_OPERATORS];
    double rate_denominator; /* rate_ts rate_scale */
    double velocity_gain;
    double previous_input; /* x(k-1) */
    int solve;
    double solve_min;
    double solve_max;

    fts_feedback fb; /* the feedback stage */

    int has_repetitive;
    size_t rc_period;
    double rc_fraction;
    size_t rc_half;
    double rc_q[FTS_MAX_Q_HALF + 1];
    size_t rc_lead;
    double rc_gain;
    double rc_memory[FTS_MAX_PERIOD];            /* d(j) at j mod FTS_MAX_PERIOD */
    double rc_outputs[FTS_MAX_LEAD + 1];         /* v(j) at j mod (FTS_MAX_LEAD + 1) */
    double rc_references[FTS_MAX_RC_PREVIEW + 1]; /* r(j + preview) */
    size_t rc_k;                                 /* samples stepped, mod FTS_MAX_PERIOD */
    int rc_started;
} fts_controller;

/* A learned feedforward table (fts ilc) played one sample per step: pass
 * fts_table_next() as the learned input of fts_step_signals. The samples
 * stay the caller's (a static const array in flash): nothing is copied. */
typedef struct fts_table {
    const double *samples;
    size_t len;
    size_t next;
} fts_table;

/* Checks and copies the coefficients; the controller starts at rest. On an
 * error *field (when field is not NULL) names the offending list, e.g.
 * "zpetc.den", as the Rust runtime does, and ctl is unusable. */
fts_status fts_init(fts_controller *ctl, const fts_spec *spec, const char **field);

/* Back to rest: filter, operators, integrator, derivative, states and the
 * repetitive memory cleared. */
void fts_reset(fts_controller *ctl);

/* Samples of reference look-ahead the caller must supply. */
size_t fts_preview(const fts_controller *ctl);

/* One command: reference_ahead is r(k + preview), measurement is x(k). */
double fts_step(fts_controller *ctl, double reference_ahead, double measurement);

/* The same, with the intermediate signals r_f + c (the loop's reference: the
 * filtered reference plus the repetitive correction) and u_ff (either pointer
 * may be NULL). */
double fts_step_traced(fts_controller *ctl, double reference_ahead, double measurement,
                       double *filtered, double *feedforward);

/* One command with the learned feedforward sample f(k) (fts_table_next(); 0.0
 * without a table) added to the loop's reference, and every signal: r_f,
 * the correction c = v + f, u_ff (each pointer may be NULL). fts_step is
 * this with learned = 0.0. */
double fts_step_signals(fts_controller *ctl, double reference_ahead, double measurement,
                        double learned, double *filtered, double *correction,
                        double *feedforward);

/* A player at the table's start. Refuses an empty table (FTS_ERR_BAD_LENGTH)
 * and a non-finite sample (FTS_ERR_NON_FINITE), *field (when field is not
 * NULL) naming "feedforward_table.samples"; a refused player plays zeros. */
fts_status fts_table_init(fts_table *t, const double *samples, size_t len, const char **field);

/* The next sample, 0.0 once the table is exhausted. */
double fts_table_next(fts_table *t);

/* Back to the first sample (a new run). */
void fts_table_rewind(fts_table *t);

/* Checks and loads the three axis controllers and, when cross is not NULL,
 * the cross-coupling controller; all start at rest. An axis or coupling
 * without a controller (FTS_FEEDBACK_NONE) is refused with *field
 * "axes.feedback" or "cross_coupling"; other errors name the list, as
 * fts_init does. */
fts_status fts_multiaxis_init(fts_multiaxis *m, const fts_feedback_spec axes[3],
                              const fts_feedback_spec *cross, const char **field);

/* Back to rest: every integrator, derivative and state cleared. */
void fts_multiaxis_reset(fts_multiaxis *m);

/* One sample: command[i] for reference[i], tangent[i] (a unit vector) and
 * measurement[i], i = x, y, z. */
void fts_multiaxis_step(fts_multiaxis *m, const double reference[3], const double tangent[3],
                        const double measurement[3], double command[3]);

/* +infinity, for state-space limits that are absent (-fts_infinity() below). */
double fts_infinity(void);

/* A short English name of a status, e.g. "non-finite coefficient". */
const char *fts_status_text(fts_status status);

#ifdef __cplusplus
}
#endif

#endif /* FTS_RUNTIME_H */
