/* The contact law's creep-force surface (core/contact/surface.py): a uniform cubic tensor B-spline in four
 * variables, the compactified normalised creepages z0, z1, z2 in [-1, 1] and log(a/b), with three outputs
 * (Fx/(mu N), Fy/(mu N), Mz/(mu N a)), evaluated with its exact first derivatives.
 *
 * It implements CasADi's external-function interface for SURFACE (z[3], log_ratio) -> f[3] with its Jacobian
 * jac_SURFACE (z[3], log_ratio, f) -> (df/dz [3x3], df/dlog_ratio [3x1]), and for what the model calls,
 * SURFACE_pair and SURFACE_pair_jac_value (below); surface.py substitutes SURFACE by a name that carries the
 * table's digest, so a compiled model can only bind to the table it was built with.
 * The coefficients are not in this file: surface.py hands them over once, through SURFACE_init, as a C-ordered
 * array [output][ratio][z2][z1][z0] of doubles, which it keeps alive for the life of the process.
 *
 * A patch's a/b is fixed by its geometry, so most calls repeat a few values of log(a/b). For each value seen
 * the library blends the four ratio planes once into a three-dimensional table (up to BLENDED of them, kept
 * for the life of the process; past that, calls evaluate all four planes): a call then costs a quarter. The
 * blended tables are added under a mutex and published with a release store, so concurrent evaluations
 * (CasADi's thread map) only read finished tables.
 */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

typedef long long int casadi_int;
typedef double casadi_real;

static const double *coef = 0;
static int nz = 0, nr = 0;             /* coefficients per z axis, along log(a/b) */
static double z_step = 1.0, r_first = 0.0, r_step = 1.0;

#define BLENDED 16
static struct { double log_ratio; double *table; } blended[BLENDED];
static int n_blended = 0;
static pthread_mutex_t blend_lock = PTHREAD_MUTEX_INITIALIZER;

void SURFACE_init(const double *table, int n_z, int n_r, double zstep, double rfirst, double rstep) {
    coef = table; nz = n_z; nr = n_r; z_step = zstep; r_first = rfirst; r_step = rstep;
}

/* weights of the four cubic B-splines that overlap a cell, and their derivatives, at t in [0, 1] */
static void basis(double t, double scale, double *w, double *d) {
    double t2 = t * t, t3 = t2 * t, s = 1.0 - t;
    w[0] = s * s * s / 6.0; w[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
    w[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0; w[3] = t3 / 6.0;
    d[0] = -0.5 * s * s * scale; d[1] = (1.5 * t2 - 2.0 * t) * scale;
    d[2] = (-1.5 * t2 + t + 0.5) * scale; d[3] = 0.5 * t2 * scale;
}

/* the cell of u (in units of the knot step, first cell 0) and the position t in it, clamped to the table */
static int cell(double u, int cells, double *t) {
    int c = (int)floor(u);
    if (c < 0) c = 0;
    if (c > cells - 1) c = cells - 1;
    *t = u - c;
    return c;
}

static void ratio_weights(double lr, int *c3, double *w, double *d) {
    double t;
    *c3 = cell((lr - r_first) / r_step, nr - 3, &t);
    basis(t, 1.0 / r_step, w, d);
}

/* the table blended at log(a/b) = lr, [output][z2][z1][z0]: made on first use, or NULL when BLENDED are made */
static const double *blended_table(double lr) {
    int n = __atomic_load_n(&n_blended, __ATOMIC_ACQUIRE);
    for (int k = 0; k < n; k++)
        if (blended[k].log_ratio == lr) return blended[k].table;
    const double *found = 0;
    pthread_mutex_lock(&blend_lock);
    for (int k = 0; k < n_blended && !found; k++)
        if (blended[k].log_ratio == lr) found = blended[k].table;
    if (!found && n_blended < BLENDED) {
        const long s3 = (long)nz * nz * nz;
        double w[4], d[4], *t = malloc(3 * s3 * sizeof(double));
        int c3;
        if (t) {
            ratio_weights(lr, &c3, w, d);
            for (int o = 0; o < 3; o++)
                for (long i = 0; i < s3; i++) {
                    const double *p = coef + (o * (long)nr + c3) * s3 + i;
                    t[o * s3 + i] = w[0] * p[0] + w[1] * p[s3] + w[2] * p[2 * s3] + w[3] * p[3 * s3];
                }
            blended[n_blended].log_ratio = lr;
            blended[n_blended].table = t;
            __atomic_store_n(&n_blended, n_blended + 1, __ATOMIC_RELEASE);
            found = t;
        }
    }
    pthread_mutex_unlock(&blend_lock);
    return found;
}

static void evaluate4(const double *z, double lr, double *f, double *J);

/* f[3] and, if J, J[k*3 + o] = d f_o / d z_k, on a three-dimensional table [output][z2][z1][z0] */
static void evaluate3(const double *table, const double *z, double *f, double *J) {
    double w[3][4], d[3][4], t;
    int c[3];
    for (int k = 0; k < 3; k++) {
        c[k] = cell((z[k] + 1.0) / z_step, nz - 3, &t);
        basis(t, 1.0 / z_step, w[k], d[k]);
    }
    memset(f, 0, 3 * sizeof(double));
    if (J) memset(J, 0, 9 * sizeof(double));
    const long s1 = nz, s2 = (long)nz * nz, so = (long)nz * nz * nz;
    for (int i2 = 0; i2 < 4; i2++)
        for (int i1 = 0; i1 < 4; i1++) {
            long base = c[0] + s1 * (c[1] + i1) + s2 * (c[2] + i2);
            double a = w[1][i1] * w[2][i2], a1 = d[1][i1] * w[2][i2], a2 = w[1][i1] * d[2][i2];
            for (int o = 0; o < 3; o++) {
                const double *p = table + o * so + base;
                double s = p[0] * w[0][0] + p[1] * w[0][1] + p[2] * w[0][2] + p[3] * w[0][3];
                f[o] += s * a;
                if (J) {
                    J[o] += (p[0] * d[0][0] + p[1] * d[0][1] + p[2] * d[0][2] + p[3] * d[0][3]) * a;
                    J[3 + o] += s * a1;
                    J[6 + o] += s * a2;
                }
            }
        }
}

/* f[3]; if J: J[k*3 + o] = d f_o / d x_k, x = (z0, z1, z2, log_ratio); the ratio column only if `ratio` */
static void evaluate(const double *z, double lr, double *f, double *J, int ratio) {
    const double *table = ratio ? 0 : blended_table(lr);
    if (table) {
        evaluate3(table, z, f, J);
        return;
    }
    evaluate4(z, lr, f, J);
}

/* all four ratio planes at once (a log(a/b) past the blended tables, or the derivative in it) */
static void evaluate4(const double *z, double lr, double *f, double *J) {
    double w[4][4], d[4][4], t;
    int c[4];
    for (int k = 0; k < 3; k++) {
        c[k] = cell((z[k] + 1.0) / z_step, nz - 3, &t);
        basis(t, 1.0 / z_step, w[k], d[k]);
    }
    ratio_weights(lr, &c[3], w[3], d[3]);
    memset(f, 0, 3 * sizeof(double));
    if (J) memset(J, 0, 12 * sizeof(double));
    const long s1 = nz, s2 = (long)nz * nz, s3 = (long)nz * nz * nz, so = s3 * nr;
    for (int i3 = 0; i3 < 4; i3++)
        for (int i2 = 0; i2 < 4; i2++)
            for (int i1 = 0; i1 < 4; i1++) {
                long base = c[0] + s1 * (c[1] + i1) + s2 * (c[2] + i2) + s3 * (c[3] + i3);
                double a = w[1][i1] * w[2][i2] * w[3][i3];
                double a1 = d[1][i1] * w[2][i2] * w[3][i3], a2 = w[1][i1] * d[2][i2] * w[3][i3];
                double a3 = w[1][i1] * w[2][i2] * d[3][i3];
                for (int o = 0; o < 3; o++) {
                    const double *p = coef + o * so + base;
                    double s = p[0] * w[0][0] + p[1] * w[0][1] + p[2] * w[0][2] + p[3] * w[0][3];
                    f[o] += s * a;
                    if (J) {
                        J[o] += (p[0] * d[0][0] + p[1] * d[0][1] + p[2] * d[0][2] + p[3] * d[0][3]) * a;
                        J[3 + o] += s * a1;
                        J[6 + o] += s * a2;
                        J[9 + o] += s * a3;
                    }
                }
            }
}

/* CasADi's external-function interface (sparsity: nrow, ncol, colind[ncol+1], row[nnz]) */
static const casadi_int sp_vector3[] = {3, 1, 0, 3, 0, 1, 2};
static const casadi_int sp_scalar[] = {1, 1, 0, 1, 0};
static const casadi_int sp_matrix33[] = {3, 3, 0, 3, 6, 9, 0, 1, 2, 0, 1, 2, 0, 1, 2};
static const casadi_int sp_unused3[] = {3, 1, 0, 0};

casadi_int SURFACE_n_in(void) { return 2; }
casadi_int SURFACE_n_out(void) { return 1; }
const casadi_int *SURFACE_sparsity_in(casadi_int i) { return i == 0 ? sp_vector3 : sp_scalar; }
const casadi_int *SURFACE_sparsity_out(casadi_int i) { return sp_vector3; }
int SURFACE_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w) {
    *sz_arg = 2; *sz_res = 1; *sz_iw = 0; *sz_w = 0;
    return 0;
}
int SURFACE(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem) {
    double f[3];
    evaluate(arg[0], arg[1][0], f, 0, 0);
    if (res[0]) memcpy(res[0], f, sizeof f);
    return 0;
}

casadi_int jac_SURFACE_n_in(void) { return 3; }
casadi_int jac_SURFACE_n_out(void) { return 2; }
const casadi_int *jac_SURFACE_sparsity_in(casadi_int i) { return i == 0 ? sp_vector3 : i == 1 ? sp_scalar : sp_unused3; }
const casadi_int *jac_SURFACE_sparsity_out(casadi_int i) { return i == 0 ? sp_matrix33 : sp_vector3; }
int jac_SURFACE_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w) {
    *sz_arg = 3; *sz_res = 2; *sz_iw = 0; *sz_w = 0;
    return 0;
}
int jac_SURFACE(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem) {
    double f[3], J[12];
    evaluate(arg[0], arg[1][0], f, J, res[1] != 0);
    if (res[0]) memcpy(res[0], J, 9 * sizeof(double));
    if (res[1]) memcpy(res[1], J + 9, 3 * sizeof(double));
    return 0;
}

/* SURFACE_pair: the law at a contact, (z+ [3], z- [3], log_ratio, w) -> w s f(z+) + (1 - w) s' f(z-), with
 * s = (1, 1, 1) and s' = (1, 1, -1): the surface at the creepages of the two rolling senses σ = +1 and -1,
 * weighted, the moment taken with its sense's sign (core/contact/laws.py: a contact that barely rolls takes the
 * mean). w is 0 or 1 except at such contacts, and only the side that counts is evaluated. SURFACE_pair_jac_value
 * returns the value and its derivatives in each argument in one pass: d/dz+ [3x3], d/dz- [3x3], d/dlog_ratio
 * [3x1], d/dw [3x1] (d/dw is 0 outside the blend, where w's own derivative vanishes). */
static void pair(const double **arg, double *f, double *Jp, double *Jm, double *Jr, double *Jw) {
    double w = arg[3][0], lr = arg[2][0], fp[3] = {0, 0, 0}, fm[3] = {0, 0, 0}, J[2][12];
    int want_ratio = Jr != 0, jac = Jp || Jm || Jr;
    memset(J, 0, sizeof J);
    if (w != 0.0) evaluate(arg[0], lr, fp, jac ? J[0] : 0, want_ratio);
    if (w != 1.0) evaluate(arg[1], lr, fm, jac ? J[1] : 0, want_ratio);
    for (int o = 0; o < 3; o++) {
        double s = o == 2 ? -1.0 : 1.0;      /* the moment's sign in the σ = -1 sense */
        f[o] = w * fp[o] + (1.0 - w) * s * fm[o];
        if (Jw) Jw[o] = (w != 0.0 && w != 1.0) ? fp[o] - s * fm[o] : 0.0;
        if (Jr) Jr[o] = w * J[0][9 + o] + (1.0 - w) * s * J[1][9 + o];
        for (int k = 0; k < 3; k++) {        /* J[side][k*3 + o] = d f_o / d z_k */
            if (Jp) Jp[k * 3 + o] = w * J[0][k * 3 + o];
            if (Jm) Jm[k * 3 + o] = (1.0 - w) * s * J[1][k * 3 + o];
        }
    }
}

casadi_int SURFACE_pair_n_in(void) { return 4; }
casadi_int SURFACE_pair_n_out(void) { return 1; }
const casadi_int *SURFACE_pair_sparsity_in(casadi_int i) { return i < 2 ? sp_vector3 : sp_scalar; }
const casadi_int *SURFACE_pair_sparsity_out(casadi_int i) { return sp_vector3; }
int SURFACE_pair_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w) {
    *sz_arg = 4; *sz_res = 1; *sz_iw = 0; *sz_w = 0;
    return 0;
}
int SURFACE_pair(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem) {
    double f[3];
    pair(arg, f, 0, 0, 0, 0);
    if (res[0]) memcpy(res[0], f, sizeof f);
    return 0;
}

casadi_int SURFACE_pair_jac_value_n_in(void) { return 4; }
casadi_int SURFACE_pair_jac_value_n_out(void) { return 5; }
const casadi_int *SURFACE_pair_jac_value_sparsity_in(casadi_int i) { return i < 2 ? sp_vector3 : sp_scalar; }
const casadi_int *SURFACE_pair_jac_value_sparsity_out(casadi_int i) { return i == 1 || i == 2 ? sp_matrix33 : sp_vector3; }
int SURFACE_pair_jac_value_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw, casadi_int *sz_w) {
    *sz_arg = 4; *sz_res = 5; *sz_iw = 0; *sz_w = 0;
    return 0;
}
int SURFACE_pair_jac_value(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem) {
    double f[3];
    pair(arg, f, res[1], res[2], res[3], res[4]);
    if (res[0]) memcpy(res[0], f, sizeof f);
    return 0;
}
