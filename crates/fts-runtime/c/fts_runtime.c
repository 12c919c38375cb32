/* fts_runtime.c: the fts controller step in C99; see fts_runtime.h.
 *
 * Every function mirrors its namesake in crates/fts-runtime/src/lib.rs
 * operation for operation (same sums in the same order, same comparisons),
 * which is what makes the commands bit-identical to the Rust step. Keep the
 * two in step: tests/suite/c_runtime.rs compares them over 1e5-sample traces. */
#include "fts_runtime.h"

#include <stdint.h>

/* Only freestanding headers (no math.h, no string.h): the runtime builds
 * for bare-metal targets without a C library. Bit patterns go through a
 * union, which C99 defines (6.5.2.3) and C++ compilers support. */
typedef union {
    double f;
    uint64_t i;
} fts_bits;

/* The repetitive compensator's rings (Rust LEAD_RING, REFERENCE_RING). */
#define FTS_LEAD_RING ((size_t)FTS_MAX_LEAD + 1)
#define FTS_REFERENCE_RING ((size_t)FTS_MAX_RC_PREVIEW + 1)
#define FTS_POWER_OF_TWO(n) ((n) != 0 && ((n) & ((n) - 1)) == 0)

/* Every ring length is a power of two no longer than the memory, so one
 * counter modulo FTS_MAX_PERIOD indexes them all (a compile-time check:
 * the array length is negative otherwise). */
typedef char fts_ring_lengths_are_powers_of_two
    [(FTS_POWER_OF_TWO((size_t)FTS_MAX_PERIOD) && FTS_POWER_OF_TWO(FTS_LEAD_RING) &&
      FTS_POWER_OF_TWO(FTS_REFERENCE_RING) && FTS_LEAD_RING <= (size_t)FTS_MAX_PERIOD &&
      FTS_REFERENCE_RING <= (size_t)FTS_MAX_PERIOD)
         ? 1
         : -1];

static uint64_t bits_of(double x)
{
    fts_bits b;
    b.f = x;
    return b.i;
}

static double from_bits(uint64_t i)
{
    fts_bits b;
    b.i = i;
    return b.f;
}

/* Exponent all ones: infinity or NaN. */
static int is_finite(double x)
{
    return ((bits_of(x) >> 52) & 0x7ffu) != 0x7ffu;
}

static int is_nan(double x)
{
    return !is_finite(x) && (bits_of(x) & 0xfffffffffffffull) != 0;
}

double fts_infinity(void)
{
    return from_bits((uint64_t)0x7ff0000000000000ull);
}

/* The cube root, the Rust crate's `cbrt` (FreeBSD s_cbrt.c as in musl,
 * error < 0.667 ulp), operation for operation: the C library's cbrt differs
 * between platforms, this one gives the same bits everywhere. */
static double fts_cbrt(double x)
{
    static const uint32_t B1 = 715094163u; /* (1023 - 1023/3 - 0.03306235651) * 2^20 */
    static const uint32_t B2 = 696219795u; /* (1023 - 1023/3 - 54/3 - 0.03306235651) * 2^20 */
    static const double P0 = 1.87595182427177009643;   /* 0x3ffe03e6 0f61e692 */
    static const double P1 = -1.88497979543377169875;  /* 0xbffe28e0 92f02420 */
    static const double P2 = 1.621429720105354466140;  /* 0x3ff9f160 4a49d6c2 */
    static const double P3 = -0.758397934778766047437; /* 0xbfe844cb bee751d9 */
    static const double P4 = 0.145996192886612446982;  /* 0x3fc2b000 d4e4edd7 */
    static const double two54 = 18014398509481984.0;   /* 2^54 */
    uint64_t ui;
    uint32_t hx;
    double t, r, s, w;
    ui = bits_of(x);
    hx = (uint32_t)(ui >> 32) & 0x7fffffffu;
    if (hx >= 0x7ff00000u) {
        return x + x; /* NaN, infinities */
    }
    if (hx < 0x00100000u) {
        t = x * two54; /* subnormals */
        ui = bits_of(t);
        hx = (uint32_t)(ui >> 32) & 0x7fffffffu;
        if (hx == 0) {
            return x; /* +-0 */
        }
        hx = hx / 3 + B2;
    } else {
        hx = hx / 3 + B1;
    }
    ui &= (uint64_t)1 << 63;
    ui |= (uint64_t)hx << 32;
    t = from_bits(ui);
    r = (t * t) * (t / x);
    t = t * ((P0 + r * (P1 + r * P2)) + ((r * r) * r) * (P3 + r * P4));
    ui = (bits_of(t) + 0x80000000u) & (uint64_t)0xffffffffc0000000ull;
    t = from_bits(ui);
    s = t * t;
    r = x / s;
    w = t + t;
    r = (r - t) / (w + r);
    return t + t * r;
}

/* Length in 1..=cap and every value finite, then copy (Rust copy_into). */
static fts_status copy_into(const double *src, size_t len, double *dst, size_t cap)
{
    size_t i;
    if (len == 0 || len > cap || src == NULL) {
        return FTS_ERR_BAD_LENGTH;
    }
    for (i = 0; i < len; ++i) {
        if (!is_finite(src[i])) {
            return FTS_ERR_NON_FINITE;
        }
    }
    for (i = 0; i < len; ++i) {
        dst[i] = src[i];
    }
    return FTS_OK;
}

static void zero(double *v, size_t len)
{
    size_t i;
    for (i = 0; i < len; ++i) {
        v[i] = 0.0;
    }
}

#define FTS_CHECK(expr, name)                                                                      \
    do {                                                                                           \
        fts_status s_ = (expr);                                                                    \
        if (s_ != FTS_OK) {                                                                        \
            *field = (name);                                                                       \
            return s_;                                                                             \
        }                                                                                          \
    } while (0)

#define FTS_FAIL(status, name)                                                                     \
    do {                                                                                           \
        *field = (name);                                                                           \
        return (status);                                                                           \
    } while (0)

static fts_status finite_or(double v)
{
    return is_finite(v) ? FTS_OK : FTS_ERR_NON_FINITE;
}

static fts_status init_zpetc(fts_controller *c, const fts_zpetc_spec *z, const char **field)
{
    double num[FTS_MAX_FILTER_LEN];
    double den[FTS_MAX_FILTER_LEN];
    double a0;
    size_t i;
    FTS_CHECK(copy_into(z->num, z->num_len, num, FTS_MAX_FILTER_LEN), "zpetc.num");
    FTS_CHECK(copy_into(z->den, z->den_len, den, FTS_MAX_FILTER_LEN), "zpetc.den");
    if (den[0] == 0.0) {
        FTS_FAIL(FTS_ERR_INVALID, "zpetc.den");
    }
    /* Normalised by a0 exactly as the Rust block (and lti::TdfFilter). */
    a0 = den[0];
    c->has_zpetc = 1;
    c->preview = z->preview;
    c->order = (z->num_len > z->den_len ? z->num_len : z->den_len) - 1;
    zero(c->zb, FTS_MAX_FILTER_LEN);
    zero(c->za, FTS_MAX_FILTER_LEN);
    for (i = 0; i < z->num_len; ++i) {
        c->zb[i] = num[i] / a0;
    }
    for (i = 0; i < z->den_len; ++i) {
        c->za[i] = den[i] / a0;
    }
    return FTS_OK;
}

/* A dead-zone stage (Rust DeadZoneBank::new): both lists empty is none. */
static fts_status dead_zone_bank(const double *thresholds, size_t thresholds_len,
                                 const double *weights, size_t weights_len, double *t_out,
                                 double *w_out, size_t *n, const char *t_field,
                                 const char *w_field, const char **field)
{
    *n = 0;
    if (thresholds_len == 0 && weights_len == 0) {
        return FTS_OK;
    }
    FTS_CHECK(copy_into(thresholds, thresholds_len, t_out, FTS_MAX_DEAD_ZONES), t_field);
    FTS_CHECK(copy_into(weights, weights_len, w_out, FTS_MAX_DEAD_ZONES), w_field);
    if (weights_len != thresholds_len) {
        FTS_FAIL(FTS_ERR_LENGTH_MISMATCH, w_field);
    }
    *n = thresholds_len;
    return FTS_OK;
}

static fts_status init_hysteresis(fts_controller *c, const fts_hysteresis_spec *h,
                                  const char **field)
{
    FTS_CHECK(copy_into(h->thresholds, h->thresholds_len, c->thresholds, FTS_MAX_OPERATORS),
              "hysteresis.thresholds");
    FTS_CHECK(copy_into(h->weights, h->weights_len, c->weights, FTS_MAX_OPERATORS),
              "hysteresis.weights");
    if (h->weights_len != h->thresholds_len) {
        FTS_FAIL(FTS_ERR_LENGTH_MISMATCH, "hysteresis.weights");
    }
    FTS_CHECK(finite_or(h->cbrt_gain), "hysteresis.cbrt_gain");
    FTS_CHECK(finite_or(h->offset), "hysteresis.offset");
    FTS_CHECK(finite_or(h->input_offset), "hysteresis.input_offset");
    {
        fts_status s = dead_zone_bank(h->dead_zone_thresholds, h->dead_zone_thresholds_len,
                                      h->dead_zone_weights, h->dead_zone_weights_len,
                                      c->dz_thresholds, c->dz_weights, &c->n_dead_zones,
                                      "hysteresis.dead_zone.thresholds",
                                      "hysteresis.dead_zone.weights", field);
        if (s != FTS_OK) {
            return s;
        }
        s = dead_zone_bank(h->input_dead_zone_thresholds, h->input_dead_zone_thresholds_len,
                           h->input_dead_zone_weights, h->input_dead_zone_weights_len,
                           c->idz_thresholds, c->idz_weights, &c->n_input_dead_zones,
                           "hysteresis.input_dead_zone.thresholds",
                           "hysteresis.input_dead_zone.weights", field);
        if (s != FTS_OK) {
            return s;
        }
    }
    c->has_rate = 0;
    if (h->rate_weights_len != 0) {
        FTS_CHECK(copy_into(h->rate_weights, h->rate_weights_len, c->rate_weights,
                            FTS_MAX_OPERATORS),
                  "hysteresis.rate_weights");
        if (h->rate_weights_len != h->thresholds_len) {
            FTS_FAIL(FTS_ERR_LENGTH_MISMATCH, "hysteresis.rate_weights");
        }
        FTS_CHECK(finite_or(h->velocity_gain), "hysteresis.velocity_gain");
        FTS_CHECK(finite_or(h->rate_ts), "hysteresis.rate_ts");
        if (h->rate_ts <= 0.0) {
            FTS_FAIL(FTS_ERR_INVALID, "hysteresis.rate_ts");
        }
        FTS_CHECK(finite_or(h->rate_scale), "hysteresis.rate_scale");
        if (h->rate_scale <= 0.0) {
            FTS_FAIL(FTS_ERR_INVALID, "hysteresis.rate_scale");
        }
        c->has_rate = 1;
    }
    c->rate_denominator = h->rate_ts * h->rate_scale;
    c->velocity_gain = h->velocity_gain;
    c->solve = h->solve != 0;
    if (c->solve) {
        FTS_CHECK(finite_or(h->solve_min), "hysteresis.solve");
        FTS_CHECK(finite_or(h->solve_max), "hysteresis.solve");
        if (!(h->solve_min < h->solve_max)) {
            FTS_FAIL(FTS_ERR_INVALID, "hysteresis.solve");
        }
    }
    c->solve_min = h->solve_min;
    c->solve_max = h->solve_max;
    c->has_hysteresis = 1;
    c->form = h->form;
    c->n_operators = h->thresholds_len;
    c->cbrt_gain = h->cbrt_gain;
    c->offset = h->offset;
    c->input_offset = h->input_offset;
    return FTS_OK;
}

static fts_status init_pid(fts_feedback *c, const fts_pid_spec *p, int filtered,
                           const char **field)
{
    FTS_CHECK(finite_or(p->kp), "pid.kp");
    FTS_CHECK(finite_or(p->ki), "pid.ki");
    FTS_CHECK(finite_or(p->kd), "pid.kd");
    FTS_CHECK(finite_or(p->output_min), "pid.output_min");
    FTS_CHECK(finite_or(p->output_max), "pid.output_max");
    if (p->output_min >= p->output_max) {
        FTS_FAIL(FTS_ERR_INVALID, "pid.output_min");
    }
    if (filtered) {
        FTS_CHECK(finite_or(p->derivative_pole), "pid.derivative_pole");
        if (!(p->derivative_pole >= 0.0 && p->derivative_pole < 1.0)) {
            FTS_FAIL(FTS_ERR_INVALID, "pid.derivative_pole");
        }
    }
    c->pid = *p;
    if (!filtered) {
        c->pid.derivative_pole = 0.0;
    }
    return FTS_OK;
}

static fts_status all_finite(const double *v, size_t len)
{
    size_t i;
    for (i = 0; i < len; ++i) {
        if (!is_finite(v[i])) {
            return FTS_ERR_NON_FINITE;
        }
    }
    return FTS_OK;
}

static fts_status init_ss(fts_feedback *c, const fts_ss_spec *k, const char **field)
{
    size_t i, j, n = k->n;
    if (n > FTS_MAX_SS_ORDER) {
        FTS_FAIL(FTS_ERR_ORDER_TOO_HIGH, "state_space.a");
    }
    if (n > 0 && (k->a == NULL || k->b == NULL || k->c == NULL)) {
        FTS_FAIL(FTS_ERR_LENGTH_MISMATCH, "state_space.a");
    }
    FTS_CHECK(all_finite(k->a, n * n), "state_space.a");
    FTS_CHECK(all_finite(k->b, n), "state_space.b");
    FTS_CHECK(all_finite(k->c, n), "state_space.c");
    FTS_CHECK(finite_or(k->d), "state_space.d");
    /* Infinite limits mean "no limit"; NaN is refused. */
    if (is_nan(k->output_min) || (!is_finite(k->output_min) && k->output_min > 0.0)) {
        FTS_FAIL(FTS_ERR_NON_FINITE, "state_space.output_min");
    }
    if (is_nan(k->output_max) || (!is_finite(k->output_max) && k->output_max < 0.0)) {
        FTS_FAIL(FTS_ERR_NON_FINITE, "state_space.output_max");
    }
    if (k->output_min >= k->output_max) {
        FTS_FAIL(FTS_ERR_INVALID, "state_space.output_min");
    }
    c->nx = n;
    for (i = 0; i < FTS_MAX_SS_ORDER; ++i) {
        zero(c->ss_a[i], FTS_MAX_SS_ORDER);
    }
    zero(c->ss_b, FTS_MAX_SS_ORDER);
    zero(c->ss_c, FTS_MAX_SS_ORDER);
    for (i = 0; i < n; ++i) {
        for (j = 0; j < n; ++j) {
            c->ss_a[i][j] = k->a[i * n + j];
        }
        c->ss_b[i] = k->b[i];
        c->ss_c[i] = k->c[i];
    }
    c->ss_d = k->d;
    c->ss_min = k->output_min;
    c->ss_max = k->output_max;
    c->conditional_update = k->conditional_update != 0;
    return FTS_OK;
}

/* The repetitive block's checks, in the order of Rust RepetitiveBlock::new;
 * preview is the ZPETC's look-ahead, undone to form the error. */
static fts_status init_repetitive(fts_controller *c, const fts_repetitive_spec *r,
                                  size_t preview, const char **field)
{
    size_t half;
    FTS_CHECK(copy_into(r->q, r->q_len, c->rc_q, FTS_MAX_Q_HALF + 1), "repetitive.q");
    half = r->q_len - 1;
    FTS_CHECK(finite_or(r->gain), "repetitive.gain");
    FTS_CHECK(finite_or(r->fraction), "repetitive.fraction");
    if (!(r->fraction >= 0.0 && r->fraction < 1.0)) {
        FTS_FAIL(FTS_ERR_INVALID, "repetitive.fraction");
    }
    if (r->lead > FTS_MAX_LEAD) {
        FTS_FAIL(FTS_ERR_BAD_LENGTH, "repetitive.lead");
    }
    /* Q and the lead reach half + lead samples ahead inside the period; one
     * more keeps v(k) from depending on itself. */
    if (r->period <= half + r->lead) {
        FTS_FAIL(FTS_ERR_INVALID, "repetitive.period");
    }
    /* period + half + 2 > FTS_MAX_PERIOD, without overflow. */
    if (half + 2 > (size_t)FTS_MAX_PERIOD || r->period > (size_t)FTS_MAX_PERIOD - half - 2) {
        FTS_FAIL(FTS_ERR_BAD_LENGTH, "repetitive.period");
    }
    if (preview > FTS_MAX_RC_PREVIEW) {
        FTS_FAIL(FTS_ERR_BAD_LENGTH, "repetitive.preview");
    }
    c->has_repetitive = 1;
    c->rc_period = r->period;
    c->rc_fraction = r->fraction;
    c->rc_half = half;
    c->rc_lead = r->lead;
    c->rc_gain = r->gain;
    return FTS_OK;
}

/* A DOB filter num/den normalised by den[0] (Rust SmallFilter::new). */
static fts_status init_small_filter(const double *num, size_t num_len, const double *den,
                                    size_t den_len, double *b, double *a, size_t *order,
                                    const char *num_field, const char *den_field,
                                    const char **field)
{
    size_t i;
    double a0;
    if (num == NULL || num_len == 0 || num_len > FTS_MAX_DOB_LEN) {
        FTS_FAIL(FTS_ERR_BAD_LENGTH, num_field);
    }
    FTS_CHECK(all_finite(num, num_len), num_field);
    if (den == NULL || den_len == 0 || den_len > FTS_MAX_DOB_LEN) {
        FTS_FAIL(FTS_ERR_BAD_LENGTH, den_field);
    }
    FTS_CHECK(all_finite(den, den_len), den_field);
    if (den[0] == 0.0) {
        FTS_FAIL(FTS_ERR_INVALID, den_field);
    }
    a0 = den[0];
    zero(b, FTS_MAX_DOB_LEN);
    zero(a, FTS_MAX_DOB_LEN);
    for (i = 0; i < num_len; ++i) {
        b[i] = num[i] / a0;
    }
    for (i = 0; i < den_len; ++i) {
        a[i] = den[i] / a0;
    }
    *order = (num_len > den_len ? num_len : den_len) - 1;
    return FTS_OK;
}

/* The DOB block (Rust DobBlock::new), checked in the same order. */
static fts_status init_dob(fts_feedback *c, const fts_ss_spec *k, const fts_dob_spec *d,
                           const char **field)
{
    static const double one = 1.0;
    size_t i;
    fts_status s = init_ss(c, k, field);
    if (s != FTS_OK) {
        return s;
    }
    s = init_small_filter(d->q_num, d->q_num_len, d->q_den, d->q_den_len, c->dob_qb, c->dob_qa,
                          &c->dob_q_order, "dob.q_num", "dob.q_den", field);
    if (s != FTS_OK) {
        return s;
    }
    if (d->inverse_num == NULL || d->inverse_num_len == 0 ||
        d->inverse_num_len > FTS_MAX_DOB_LEN) {
        FTS_FAIL(FTS_ERR_BAD_LENGTH, "dob.inverse_num");
    }
    FTS_CHECK(all_finite(d->inverse_num, d->inverse_num_len), "dob.inverse_num");
    zero(c->dob_diff, FTS_MAX_DOB_LEN);
    for (i = 0; i < d->inverse_num_len; ++i) {
        c->dob_diff[i] = d->inverse_num[i];
    }
    c->dob_diff_len = d->inverse_num_len;
    s = init_small_filter(&one, 1, d->inverse_den, d->inverse_den_len, c->dob_ib, c->dob_ia,
                          &c->dob_inv_order, "dob.inverse_den", "dob.inverse_den", field);
    if (s != FTS_OK) {
        return s;
    }
    if (d->delay == 0 || d->delay > FTS_MAX_DOB_DELAY) {
        FTS_FAIL(FTS_ERR_INVALID, "dob.delay");
    }
    FTS_CHECK(finite_or(d->coulomb), "dob.coulomb");
    FTS_CHECK(finite_or(d->viscous), "dob.viscous");
    FTS_CHECK(finite_or(d->smoothing), "dob.smoothing");
    if (d->smoothing <= 0.0) {
        FTS_FAIL(FTS_ERR_INVALID, "dob.smoothing");
    }
    FTS_CHECK(finite_or(d->ts), "dob.ts");
    if (d->ts <= 0.0) {
        FTS_FAIL(FTS_ERR_INVALID, "dob.ts");
    }
    c->dob_delay = d->delay;
    c->dob_coulomb = d->coulomb;
    c->dob_viscous = d->viscous;
    c->dob_smoothing = d->smoothing;
    c->dob_rate = 1.0 / d->ts;
    return FTS_OK;
}

/* One feedback controller (Rust Feedback::new); the kind is set on success. */
static fts_status init_feedback(fts_feedback *f, const fts_feedback_spec *spec, const char **field)
{
    fts_status s = FTS_OK;
    switch (spec->kind) {
    case FTS_FEEDBACK_NONE:
        break;
    case FTS_FEEDBACK_PID:
    case FTS_FEEDBACK_PID_FILTERED:
        s = init_pid(f, &spec->pid, spec->kind == FTS_FEEDBACK_PID_FILTERED, field);
        break;
    case FTS_FEEDBACK_STATE_SPACE:
        s = init_ss(f, &spec->ss, field);
        break;
    case FTS_FEEDBACK_DOB:
        s = init_dob(f, &spec->ss, &spec->dob, field);
        break;
    default:
        FTS_FAIL(FTS_ERR_INVALID, "feedback");
    }
    if (s == FTS_OK) {
        f->kind = spec->kind;
    }
    return s;
}

static void reset_feedback(fts_feedback *f)
{
    f->integral = 0.0;
    f->derivative = 0.0;
    f->previous_measurement = 0.0;
    f->started = 0;
    zero(f->x, FTS_MAX_SS_ORDER);
    zero(f->dob_qs, FTS_MAX_DOB_LEN);
    zero(f->dob_is, FTS_MAX_DOB_LEN);
    zero(f->dob_diffs, FTS_MAX_DOB_LEN);
    zero(f->dob_commands, FTS_MAX_DOB_DELAY);
    f->dob_head = 0;
    f->dob_last_friction = 0.0;
    f->dob_previous_reference = 0.0;
    f->dob_started = 0;
}

fts_status fts_init(fts_controller *ctl, const fts_spec *spec, const char **field)
{
    const char *unused = NULL;
    if (field == NULL) {
        field = &unused;
    }
    *field = NULL;
    ctl->has_zpetc = 0;
    ctl->preview = 0;
    ctl->order = 0;
    ctl->has_hysteresis = 0;
    ctl->fb.kind = FTS_FEEDBACK_NONE;
    ctl->has_repetitive = 0;
    if (spec->zpetc != NULL) {
        fts_status s = init_zpetc(ctl, spec->zpetc, field);
        if (s != FTS_OK) {
            return s;
        }
    }
    if (spec->hysteresis != NULL) {
        fts_status s = init_hysteresis(ctl, spec->hysteresis, field);
        if (s != FTS_OK) {
            return s;
        }
    }
    {
        fts_feedback_spec feedback;
        fts_status s;
        feedback.kind = spec->feedback;
        feedback.pid = spec->pid;
        feedback.ss = spec->ss;
        if (spec->feedback == FTS_FEEDBACK_DOB) {
            feedback.dob = spec->dob;
        }
        s = init_feedback(&ctl->fb, &feedback, field);
        if (s != FTS_OK) {
            return s;
        }
    }
    if (spec->repetitive != NULL) {
        size_t preview = spec->zpetc != NULL ? spec->zpetc->preview : 0;
        fts_status s = init_repetitive(ctl, spec->repetitive, preview, field);
        if (s != FTS_OK) {
            return s;
        }
    }
    fts_reset(ctl);
    return FTS_OK;
}

void fts_reset(fts_controller *ctl)
{
    zero(ctl->zstate, FTS_MAX_FILTER_LEN);
    zero(ctl->play, FTS_MAX_OPERATORS);
    ctl->previous_input = 0.0;
    reset_feedback(&ctl->fb);
    /* The rings are only read with a repetitive block: cleared then. */
    if (ctl->has_repetitive) {
        zero(ctl->rc_memory, FTS_MAX_PERIOD);
        zero(ctl->rc_outputs, FTS_LEAD_RING);
        zero(ctl->rc_references, FTS_REFERENCE_RING);
    }
    ctl->rc_k = 0;
    ctl->rc_started = 0;
}

size_t fts_preview(const fts_controller *ctl)
{
    return ctl->has_zpetc ? ctl->preview : 0;
}

/* Transposed direct form II (Rust tdf2_step). */
static double tdf2_step(fts_controller *c, double x)
{
    size_t i, n = c->order;
    double y;
    if (n == 0) {
        return c->zb[0] * x;
    }
    y = c->zb[0] * x + c->zstate[0];
    for (i = 0; i + 1 < n; ++i) {
        c->zstate[i] = c->zb[i + 1] * x + c->zstate[i + 1] - c->za[i + 1] * y;
    }
    c->zstate[n - 1] = c->zb[n] * x - c->za[n] * y;
    return y;
}

/* max(lower, min(upper, previous)) with the Rust comparisons (signed zeros included). */
static double play(double upper, double lower, double previous)
{
    double clipped = upper < previous ? upper : previous;
    return lower > clipped ? lower : clipped;
}

static double dead_zone(double d, double v)
{
    double t;
    if (d == 0.0) {
        return v;
    }
    t = v - d;
    return t > 0.0 ? t : 0.0;
}

/* |x| by clearing the sign bit (Rust fabs). */
static double fts_fabs(double x)
{
    return from_bits(bits_of(x) & ~((uint64_t)1 << 63));
}

/* sum_j g_j S_{d_j}[v] over a stage; v itself without one (Rust DeadZoneBank::apply). */
static double dead_zone_stage(const double *t, const double *w, size_t n, double v)
{
    double out;
    size_t i;
    if (n == 0) {
        return v;
    }
    /* -0.0 is the additive identity, as in Rust's Iterator::sum. */
    out = -0.0;
    for (i = 0; i < n; ++i) {
        out += w[i] * dead_zone(t[i], v);
    }
    return out;
}

/* The model Y(u) from the committed state (Rust hysteresis_eval): the play
 * outputs at u go to next, the controller is not changed. */
static double hysteresis_eval(const fts_controller *c, double u, double *next)
{
    double x = u - c->input_offset;
    double z = dead_zone_stage(c->idz_thresholds, c->idz_weights, c->n_input_dead_zones, x);
    double v = 0.0;
    double sigma = 0.0;
    double out;
    size_t i, n = c->n_operators;
    if (c->form == FTS_PLAY_LOWER) {
        for (i = 0; i < n; ++i) {
            next[i] = play(z + 0.0, z - c->thresholds[i], c->play[i]);
            v += c->weights[i] * next[i];
        }
    } else {
        for (i = 0; i < n; ++i) {
            next[i] = play(z + c->thresholds[i], z - c->thresholds[i], c->play[i]);
            v += c->weights[i] * next[i];
        }
    }
    if (c->has_rate) {
        double rho;
        sigma = (x - c->previous_input) / c->rate_denominator;
        rho = fts_fabs(sigma);
        for (i = 0; i < n; ++i) {
            v += c->rate_weights[i] * rho * next[i];
        }
    }
    out = dead_zone_stage(c->dz_thresholds, c->dz_weights, c->n_dead_zones, v);
    if (c->has_rate) {
        return c->offset + c->cbrt_gain * fts_cbrt(x) + out + c->velocity_gain * sigma;
    }
    return c->offset + c->cbrt_gain * fts_cbrt(x) + out;
}

/* Per-sample inversion of the forward model on [lo, hi] (Rust
 * hysteresis_solve): Illinois regula falsi with bisection, at most
 * FTS_MAX_SOLVE_ITERATIONS steps; saturates at the closer end. */
#define FTS_MAX_SOLVE_ITERATIONS 100
static double hysteresis_solve(const fts_controller *c, double target, double lo, double hi)
{
    double trial[FTS_MAX_OPERATORS];
    double y_lo, y_hi, f_a, f_b, scale, tolerance, a, b, r_a, r_b;
    int kept = 0;
    size_t it;
    y_lo = hysteresis_eval(c, lo, trial);
    f_a = y_lo - target;
    if (!(f_a < 0.0)) {
        return lo;
    }
    y_hi = hysteresis_eval(c, hi, trial);
    f_b = y_hi - target;
    if (!(f_b > 0.0)) {
        return hi;
    }
    scale = fts_fabs(y_lo) > fts_fabs(y_hi) ? fts_fabs(y_lo) : fts_fabs(y_hi);
    tolerance = 8.0 * 2.220446049250313e-16 * scale;
    a = lo;
    b = hi;
    for (it = 0; it < FTS_MAX_SOLVE_ITERATIONS; ++it) {
        double x = (a * f_b - b * f_a) / (f_b - f_a);
        double f_x;
        if (!(x > a && x < b)) {
            x = a + 0.5 * (b - a);
            if (!(x > a && x < b)) {
                break;
            }
        }
        f_x = hysteresis_eval(c, x, trial) - target;
        if (fts_fabs(f_x) <= tolerance) {
            return x;
        }
        if (f_x < 0.0) {
            a = x;
            f_a = f_x;
            if (kept == 1) {
                f_b *= 0.5;
            }
            kept = 1;
        } else {
            b = x;
            f_b = f_x;
            if (kept == -1) {
                f_a *= 0.5;
            }
            kept = -1;
        }
    }
    r_a = fts_fabs(hysteresis_eval(c, a, trial) - target);
    r_b = fts_fabs(hysteresis_eval(c, b, trial) - target);
    return r_a <= r_b ? a : b;
}

/* The hysteresis block's step (Rust hysteresis_step): evaluate or solve,
 * then commit the play states and x(k-1) at the input used. */
static double hysteresis_step(fts_controller *c, double u)
{
    double next[FTS_MAX_OPERATORS];
    double input, output;
    size_t i;
    if (c->solve) {
        input = hysteresis_solve(c, u, c->solve_min, c->solve_max);
        (void)hysteresis_eval(c, input, next);
        output = input;
    } else {
        input = u;
        output = hysteresis_eval(c, u, next);
    }
    for (i = 0; i < c->n_operators; ++i) {
        c->play[i] = next[i];
    }
    c->previous_input = input - c->input_offset;
    return output;
}

/* f64::clamp: NaN passes through. */
static double clamp(double v, double lo, double hi)
{
    if (v < lo) {
        v = lo;
    }
    if (v > hi) {
        v = hi;
    }
    return v;
}

/* The [Li21] Eq. 5 PID and its filtered-derivative form (Rust pid_step,
 * pid_filtered_step): conditional-integration anti-windup. */
static double pid_step(fts_feedback *c, double reference, double measurement,
                       double feedforward)
{
    const fts_pid_spec *p = &c->pid;
    double error = reference - measurement;
    double previous = c->started ? c->previous_measurement : measurement;
    double derivative, candidate, unclamped, command;
    int winding_up;
    if (c->kind == FTS_FEEDBACK_PID_FILTERED) {
        derivative = p->derivative_pole * c->derivative + p->kd * (measurement - previous);
        c->derivative = derivative;
    } else {
        derivative = p->kd * (measurement - previous);
    }
    c->previous_measurement = measurement;
    c->started = 1;
    candidate = c->integral + p->ki * error;
    unclamped = feedforward + p->kp * error + candidate - derivative;
    command = clamp(unclamped, p->output_min, p->output_max);
    winding_up = (unclamped > p->output_max && error > 0.0) ||
                 (unclamped < p->output_min && error < 0.0);
    if (!winding_up) {
        c->integral = candidate;
    }
    return command;
}

/* v = C x + D e from the states before the update, then x <- A x + B e unless
 * held by the conditional update (Rust ss_step). */
static double ss_step(fts_feedback *c, double error, double feedforward)
{
    double next[FTS_MAX_SS_ORDER];
    double cx = 0.0, unclamped, command;
    size_t i, j, n = c->nx;
    int hold = 0;
    for (j = 0; j < n; ++j) {
        cx += c->ss_c[j] * c->x[j];
    }
    unclamped = feedforward + (cx + c->ss_d * error);
    command = clamp(unclamped, c->ss_min, c->ss_max);
    for (i = 0; i < n; ++i) {
        double acc = 0.0;
        for (j = 0; j < n; ++j) {
            acc += c->ss_a[i][j] * c->x[j];
        }
        next[i] = acc + c->ss_b[i] * error;
    }
    if (c->conditional_update && (unclamped > c->ss_max || unclamped < c->ss_min)) {
        double cnext = 0.0;
        for (i = 0; i < n; ++i) {
            cnext += c->ss_c[i] * next[i];
        }
        hold = (unclamped > c->ss_max && cnext > cx) || (unclamped < c->ss_min && cnext < cx);
    }
    if (!hold) {
        for (i = 0; i < n; ++i) {
            c->x[i] = next[i];
        }
    }
    return command;
}

/* One sample of a DOB filter in transposed direct form II (Rust SmallFilter::step). */
static double small_filter_step(const double *b, const double *a, double *state, size_t n,
                                double x)
{
    double y;
    size_t i;
    if (n == 0) {
        return b[0] * x;
    }
    y = b[0] * x + state[0];
    for (i = 0; i + 1 < n; ++i) {
        state[i] = b[i + 1] * x + state[i + 1] - a[i + 1] * y;
    }
    state[n - 1] = b[n] * x - a[n] * y;
    return y;
}

/* A[x](k) = sum_j a_j (Delta^j x)(k) by successive differences (Rust
 * DobBlock::difference_step). */
static double dob_difference_step(fts_feedback *c, double x)
{
    double d = x, acc = c->dob_diff[0] * x;
    size_t j;
    for (j = 1; j < c->dob_diff_len; ++j) {
        double next = d - c->dob_diffs[j - 1];
        c->dob_diffs[j - 1] = d;
        d = next;
        acc += c->dob_diff[j] * d;
    }
    return acc;
}

/* The DOB step (Rust DobBlock::step). */
static double dob_step(fts_feedback *c, double reference, double measurement,
                       double feedforward)
{
    double previous = c->dob_started ? c->dob_previous_reference : reference;
    double velocity, oldest, w, estimate, abs_v, friction, ff, command;
    c->dob_previous_reference = reference;
    c->dob_started = 1;
    velocity = (reference - previous) * c->dob_rate;
    oldest = c->dob_commands[c->dob_head];
    w = small_filter_step(c->dob_ib, c->dob_ia, c->dob_is, c->dob_inv_order,
                          dob_difference_step(c, measurement)) -
        oldest;
    estimate = small_filter_step(c->dob_qb, c->dob_qa, c->dob_qs, c->dob_q_order, w);
    abs_v = velocity < 0.0 ? -velocity : velocity;
    friction = c->dob_coulomb * (velocity / (abs_v + c->dob_smoothing)) + c->dob_viscous * velocity;
    ff = feedforward - estimate + friction;
    command = ss_step(c, reference - measurement, ff);
    c->dob_last_friction = friction;
    c->dob_commands[c->dob_head] = command - friction;
    c->dob_head = (c->dob_head + 1) % c->dob_delay;
    return command;
}

/* One clamped command u_ff + K[reference - measurement] (Rust Feedback::step);
 * the kind is not FTS_FEEDBACK_NONE. */
static double feedback_step(fts_feedback *f, double reference, double measurement,
                            double feedforward)
{
    if (f->kind == FTS_FEEDBACK_STATE_SPACE) {
        return ss_step(f, reference - measurement, feedforward);
    }
    if (f->kind == FTS_FEEDBACK_DOB) {
        return dob_step(f, reference, measurement, feedforward);
    }
    return pid_step(f, reference, measurement, feedforward);
}

/* The reference r(k) from r(k + preview) (Rust delayed_reference): a delay
 * line filled with the first value passed, so that a loop starting
 * mid-stroke does not learn a step that was never asked for. */
static double rc_delayed_reference(fts_controller *c, double reference_ahead, size_t preview)
{
    size_t now;
    if (!c->rc_started) {
        size_t i;
        for (i = 0; i < FTS_REFERENCE_RING; ++i) {
            c->rc_references[i] = reference_ahead;
        }
        c->rc_started = 1;
    }
    now = c->rc_k % FTS_REFERENCE_RING;
    c->rc_references[now] = reference_ahead;
    return c->rc_references[(now + FTS_REFERENCE_RING - preview) % FTS_REFERENCE_RING];
}

/* D(j) = (1 - f) d(j) + f d(j - 1) at the memory index of j (Rust delayed). */
static double rc_delayed(const fts_controller *c, size_t index)
{
    double d = c->rc_memory[index % FTS_MAX_PERIOD];
    double older;
    if (c->rc_fraction == 0.0) {
        return d;
    }
    older = c->rc_memory[(index + FTS_MAX_PERIOD - 1) % FTS_MAX_PERIOD];
    return (1.0 - c->rc_fraction) * d + c->rc_fraction * older;
}

/* One repetitive sample (Rust RepetitiveBlock::step): returns
 * v(k) = sum_{i=-h..h} q[|i|] D(k - i - period), summed in that order, then
 * completes d(k - lead) = v(k - lead) + gain e(k). */
static double rc_step(fts_controller *c, double error)
{
    size_t i, k = c->rc_k, h = c->rc_half, m = c->rc_lead;
    double acc = 0.0, v_lead;
    for (i = 0; i <= 2 * h; ++i) {
        size_t tap = i < h ? h - i : i - h;
        /* k - (i - h) - period, shifted by a whole memory to stay unsigned. */
        size_t index = k + FTS_MAX_PERIOD + h - i - c->rc_period;
        acc += c->rc_q[tap] * rc_delayed(c, index);
    }
    c->rc_outputs[k % FTS_LEAD_RING] = acc;
    /* v(j) for j < 0 is 0: the rings start at rest. */
    v_lead = c->rc_outputs[(k + FTS_LEAD_RING - m) % FTS_LEAD_RING];
    c->rc_memory[(k + FTS_MAX_PERIOD - m) % FTS_MAX_PERIOD] = v_lead + c->rc_gain * error;
    c->rc_k = (k + 1) % FTS_MAX_PERIOD;
    return acc;
}

double fts_step_signals(fts_controller *ctl, double reference_ahead, double measurement,
                        double learned, double *filtered, double *correction,
                        double *feedforward)
{
    double rf = ctl->has_zpetc ? tdf2_step(ctl, reference_ahead) : reference_ahead;
    double repetitive = 0.0, corr, loop_reference, uff, u;
    if (ctl->has_repetitive) {
        double reference = rc_delayed_reference(ctl, reference_ahead, fts_preview(ctl));
        repetitive = rc_step(ctl, reference - measurement);
    }
    corr = repetitive + learned;
    loop_reference = rf + corr;
    uff = ctl->has_hysteresis ? hysteresis_step(ctl, loop_reference) : 0.0;
    if (ctl->fb.kind == FTS_FEEDBACK_NONE) {
        u = ctl->has_hysteresis ? uff : loop_reference;
    } else {
        u = feedback_step(&ctl->fb, loop_reference, measurement, uff);
    }
    if (filtered != NULL) {
        *filtered = rf;
    }
    if (correction != NULL) {
        *correction = corr;
    }
    if (feedforward != NULL) {
        *feedforward = uff;
    }
    return u;
}

double fts_step_traced(fts_controller *ctl, double reference_ahead, double measurement,
                       double *filtered, double *feedforward)
{
    double rf, corr;
    double u = fts_step_signals(ctl, reference_ahead, measurement, 0.0, &rf, &corr, feedforward);
    if (filtered != NULL) {
        *filtered = rf + corr;
    }
    return u;
}

double fts_step(fts_controller *ctl, double reference_ahead, double measurement)
{
    return fts_step_signals(ctl, reference_ahead, measurement, 0.0, NULL, NULL, NULL);
}

fts_status fts_table_init(fts_table *t, const double *samples, size_t len, const char **field)
{
    const char *unused = NULL;
    if (field == NULL) {
        field = &unused;
    }
    *field = NULL;
    t->samples = NULL;
    t->len = 0;
    t->next = 0;
    if (len == 0 || samples == NULL) {
        FTS_FAIL(FTS_ERR_BAD_LENGTH, "feedforward_table.samples");
    }
    FTS_CHECK(all_finite(samples, len), "feedforward_table.samples");
    t->samples = samples;
    t->len = len;
    return FTS_OK;
}

double fts_table_next(fts_table *t)
{
    if (t->next < t->len) {
        return t->samples[t->next++];
    }
    return 0.0;
}

void fts_table_rewind(fts_table *t)
{
    t->next = 0;
}

const char *fts_status_text(fts_status status)
{
    switch (status) {
    case FTS_OK:
        return "ok";
    case FTS_ERR_BAD_LENGTH:
        return "empty or beyond the runtime's capacity";
    case FTS_ERR_ORDER_TOO_HIGH:
        return "more states than FTS_MAX_SS_ORDER";
    case FTS_ERR_LENGTH_MISMATCH:
        return "length does not match its partner list";
    case FTS_ERR_NON_FINITE:
        return "contains a non-finite number";
    case FTS_ERR_INVALID:
        return "invalid value";
    }
    return "unknown status";
}

/* An axis (or the coupling) needs a feedback controller (Rust contour::controller). */
static fts_status init_axis(fts_feedback *f, const fts_feedback_spec *spec, const char *name,
                            const char **field)
{
    if (spec->kind == FTS_FEEDBACK_NONE) {
        FTS_FAIL(FTS_ERR_INVALID, name);
    }
    return init_feedback(f, spec, field);
}

fts_status fts_multiaxis_init(fts_multiaxis *m, const fts_feedback_spec axes[3],
                              const fts_feedback_spec *cross, const char **field)
{
    const char *unused = NULL;
    size_t i;
    if (field == NULL) {
        field = &unused;
    }
    *field = NULL;
    m->coupled = 0;
    for (i = 0; i < 3; ++i) {
        fts_status s = init_axis(&m->axes[i], &axes[i], "axes.feedback", field);
        if (s != FTS_OK) {
            return s;
        }
    }
    if (cross != NULL) {
        fts_status s = init_axis(&m->cross[0], cross, "cross_coupling", field);
        if (s != FTS_OK) {
            return s;
        }
        m->cross[1] = m->cross[0];
        m->cross[2] = m->cross[0];
        m->coupled = 1;
    }
    fts_multiaxis_reset(m);
    return FTS_OK;
}

void fts_multiaxis_reset(fts_multiaxis *m)
{
    size_t i;
    for (i = 0; i < 3; ++i) {
        reset_feedback(&m->axes[i]);
        reset_feedback(&m->cross[i]);
    }
}

/* Rust CrossCoupledStep::step, operation for operation. */
void fts_multiaxis_step(fts_multiaxis *m, const double reference[3], const double tangent[3],
                        const double measurement[3], double command[3])
{
    double e[3], eps[3], along;
    size_t i;
    for (i = 0; i < 3; ++i) {
        e[i] = reference[i] - measurement[i];
    }
    along = e[0] * tangent[0] + e[1] * tangent[1] + e[2] * tangent[2];
    for (i = 0; i < 3; ++i) {
        eps[i] = e[i] - along * tangent[i];
    }
    for (i = 0; i < 3; ++i) {
        command[i] = feedback_step(&m->axes[i], reference[i], measurement[i], 0.0);
    }
    if (m->coupled) {
        for (i = 0; i < 3; ++i) {
            command[i] += feedback_step(&m->cross[i], 0.0, -eps[i], 0.0);
        }
        /* A DOB axis observes the command applied (Rust Feedback::applied). */
        for (i = 0; i < 3; ++i) {
            fts_feedback *f = &m->axes[i];
            if (f->kind == FTS_FEEDBACK_DOB) {
                f->dob_commands[(f->dob_head + f->dob_delay - 1) % f->dob_delay] =
                    command[i] - f->dob_last_friction;
            }
        }
    }
}
