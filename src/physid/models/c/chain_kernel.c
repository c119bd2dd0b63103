/* physid generic rigid-chain kernel: Newton-Euler, mass matrix, regressor, PD closed loop.
 *
 * One fixed source for every chain or tree; the chain is data (a double buffer):
 *   model = [n, gx, gy, gz, joint_0 (JS doubles), joint_1, ...]
 *   joint = [type (0 revolute, 1 prismatic), R0 (9, row-major), p0 (3), axis (3),
 *            inertia in the joint frame (10: m mcx mcy mcz XX XY XZ YY YZ ZZ),
 *            drive (8: Ia Fv Fc Fvp Fvn Fcp Fcn OF), Coulomb smoothing velocity (1; 0: exact),
            parent joint (1; -1: the base; parents come before their children)]
 * With a smoothing velocity v_s > 0 (simulation only), sign(q̇) becomes tanh(q̇ / v_s) and the
 * one-sided indicators [q̇ > 0], [q̇ < 0] become (1 ± tanh(q̇ / v_s)) / 2.
 * Built once with cc -O2 and loaded with ctypes (physid.models.ckernel). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define JS 36
#define MAXJ 64

typedef struct {
    double R[MAXJ][9], p[MAXJ][3], w[MAXJ][3], dw[MAXJ][3], acc[MAXJ][3];
} kin_t;

static inline void cross(const double *a, const double *b, double *o) {
    double o0 = a[1] * b[2] - a[2] * b[1], o1 = a[2] * b[0] - a[0] * b[2], o2 = a[0] * b[1] - a[1] * b[0];
    o[0] = o0; o[1] = o1; o[2] = o2;
}
static inline void mv(const double *R, const double *v, double *o) {
    double o0 = R[0] * v[0] + R[1] * v[1] + R[2] * v[2];
    double o1 = R[3] * v[0] + R[4] * v[1] + R[5] * v[2];
    double o2 = R[6] * v[0] + R[7] * v[1] + R[8] * v[2];
    o[0] = o0; o[1] = o1; o[2] = o2;
}
static inline void mtv(const double *R, const double *v, double *o) {
    double o0 = R[0] * v[0] + R[3] * v[1] + R[6] * v[2];
    double o1 = R[1] * v[0] + R[4] * v[1] + R[7] * v[2];
    double o2 = R[2] * v[0] + R[5] * v[1] + R[8] * v[2];
    o[0] = o0; o[1] = o1; o[2] = o2;
}

static void joint_tf(const double *J, double q, double *R, double *p) {
    const double *R0 = J + 1, *p0 = J + 10, *a = J + 13;
    if (J[0] == 0.0) {
        double s = sin(q), c = 1.0 - cos(q);
        double K[9] = {0, -a[2], a[1], a[2], 0, -a[0], -a[1], a[0], 0}, Rm[9];
        int i, j, k;
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++) {
                double k2 = 0;
                for (k = 0; k < 3; k++) k2 += K[i * 3 + k] * K[k * 3 + j];
                Rm[i * 3 + j] = (i == j) + s * K[i * 3 + j] + c * k2;
            }
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++)
                R[i * 3 + j] = R0[i * 3] * Rm[j] + R0[i * 3 + 1] * Rm[3 + j] + R0[i * 3 + 2] * Rm[6 + j];
        p[0] = p0[0]; p[1] = p0[1]; p[2] = p0[2];
    } else {
        double ra[3];
        memcpy(R, R0, 9 * sizeof(double));
        mv(R0, a, ra);
        p[0] = p0[0] + q * ra[0]; p[1] = p0[1] + q * ra[1]; p[2] = p0[2] + q * ra[2];
    }
}

static void kinematics(const double *model, const double *q, const double *qd, const double *qdd,
                       int grav, kin_t *K) {
    int n = (int)model[0], i;
    double w0[3] = {0, 0, 0}, acc0[3];
    for (i = 0; i < 3; i++) acc0[i] = grav ? -model[1 + i] : 0.0;
    for (i = 0; i < n; i++) {
        const double *J = model + 4 + i * JS, *a = J + 13;
        double *R = K->R[i], *p = K->p[i], t1[3], t2[3], accp[3], win[3], w[3], dw[3], acc[3];
        int c, pi = (int)J[35];
        memcpy(w, pi < 0 ? w0 : K->w[pi], sizeof w);      /* the parent's motion (or the base's) */
        memcpy(dw, pi < 0 ? w0 : K->dw[pi], sizeof dw);
        memcpy(acc, pi < 0 ? acc0 : K->acc[pi], sizeof acc);
        joint_tf(J, q[i], R, p);
        cross(dw, p, t1);
        cross(w, p, t2);
        cross(w, t2, t2);
        for (c = 0; c < 3; c++) accp[c] = acc[c] + t1[c] + t2[c];
        mtv(R, w, win);
        mtv(R, dw, dw);
        mtv(R, accp, acc);
        if (J[0] == 0.0) {
            double aq[3] = {a[0] * qd[i], a[1] * qd[i], a[2] * qd[i]}, x[3];
            cross(win, aq, x);
            for (c = 0; c < 3; c++) {
                w[c] = win[c] + aq[c];
                dw[c] += a[c] * qdd[i] + x[c];
            }
        } else {
            double aq[3] = {a[0] * qd[i], a[1] * qd[i], a[2] * qd[i]}, x[3];
            cross(win, aq, x);
            for (c = 0; c < 3; c++) {
                w[c] = win[c];
                acc[c] += a[c] * qdd[i] + 2.0 * x[c];
            }
        }
        memcpy(K->w[i], w, sizeof w);
        memcpy(K->dw[i], dw, sizeof dw);
        memcpy(K->acc[i], acc, sizeof acc);
    }
}

static inline double sgn(double x) { return (x > 0) - (x < 0); }

static double drive_torque(const double *D, double qd, double qdd) {
    if (D[8] > 0) {
        double th = tanh(qd / D[8]), pos = 0.5 * (1 + th), neg = 0.5 * (1 - th);
        return D[0] * qdd + D[1] * qd + D[2] * th + (qd > 0 ? D[3] * qd : 0.0) + D[5] * pos +
               (qd < 0 ? D[4] * qd : 0.0) - D[6] * neg + D[7];
    }
    return D[0] * qdd + D[1] * qd + D[2] * sgn(qd) + (qd > 0 ? D[3] * qd + D[5] : 0.0) +
           (qd < 0 ? D[4] * qd - D[6] : 0.0) + D[7];
}

static void rnea_k(const double *model, const kin_t *K, const double *qd, const double *qdd,
                   int drv, double *tau) {
    int n = (int)model[0], i, c;
    double FC[MAXJ][3], NC[MAXJ][3];  /* wrenches of each joint's children, in its frame */
    memset(FC, 0, sizeof(double) * 3 * (size_t)n);
    memset(NC, 0, sizeof(double) * 3 * (size_t)n);
    for (i = n - 1; i >= 0; i--) {
        const double *J = model + 4 + i * JS, *a = J + 13, *P = J + 16, *D = J + 26;
        const double *fc = FC[i], *nc = NC[i];
        int pi = (int)J[35];
        const double *w = K->w[i], *dw = K->dw[i], *acc = K->acc[i];
        double m = P[0], h[3] = {P[1], P[2], P[3]};
        double I[9] = {P[4], P[5], P[6], P[5], P[7], P[8], P[6], P[8], P[9]};
        double f[3], nn[3], t1[3], t2[3], Iw[3], Idw[3];
        cross(dw, h, t1);
        cross(w, h, t2);
        cross(w, t2, t2);
        for (c = 0; c < 3; c++) f[c] = m * acc[c] + t1[c] + t2[c] + fc[c];
        mv(I, w, Iw);
        mv(I, dw, Idw);
        cross(w, Iw, t1);
        cross(h, acc, t2);
        for (c = 0; c < 3; c++) nn[c] = Idw[c] + t1[c] + t2[c] + nc[c];
        tau[i] = J[0] == 0.0 ? a[0] * nn[0] + a[1] * nn[1] + a[2] * nn[2]
                             : a[0] * f[0] + a[1] * f[1] + a[2] * f[2];
        if (drv) tau[i] += drive_torque(D, qd[i], qdd[i]);
        if (pi >= 0) {
            double fp[3], np_[3];
            mv(K->R[i], f, fp);
            mv(K->R[i], nn, np_);
            cross(K->p[i], fp, t1);
            for (c = 0; c < 3; c++) {
                FC[pi][c] += fp[c];
                NC[pi][c] += np_[c] + t1[c];
            }
        }
    }
}

void rnea_one(const double *model, const double *q, const double *qd, const double *qdd,
              double *tau, int grav, int drv) {
    kin_t K;
    kinematics(model, q, qd, qdd, grav, &K);
    rnea_k(model, &K, qd, qdd, drv, tau);
}

void mass_one(const double *model, const double *q, double *M) {
    int n = (int)model[0], j, i;
    double z[MAXJ], e[MAXJ], col[MAXJ];
    for (i = 0; i < n; i++) z[i] = 0.0;
    for (j = 0; j < n; j++) {
        for (i = 0; i < n; i++) e[i] = (i == j);
        rnea_one(model, q, z, e, col, 0, 0);
        for (i = 0; i < n; i++) M[i * n + j] = col[i];
    }
    for (j = 0; j < n; j++) {
        M[j * n + j] += model[4 + j * JS + 26];  /* armature */
        for (i = 0; i < j; i++) M[i * n + j] = M[j * n + i] = 0.5 * (M[i * n + j] + M[j * n + i]);
    }
}

/* q̈ = M⁻¹ (τ − h); returns 0, or −1 when M is not positive definite */
int forward_one(const double *model, const double *q, const double *qd, const double *tau,
                double *qdd) {
    int n = (int)model[0], i, j, k;
    double M[MAXJ * MAXJ], L[MAXJ * MAXJ], h[MAXJ], z[MAXJ], zero[MAXJ];
    for (i = 0; i < n; i++) zero[i] = 0.0;
    mass_one(model, q, M);
    rnea_one(model, q, qd, zero, h, 1, 1);
    for (j = 0; j < n; j++) {
        double d = M[j * n + j];
        for (k = 0; k < j; k++) d -= L[j * n + k] * L[j * n + k];
        if (!(d > 0)) return -1;
        L[j * n + j] = sqrt(d);
        for (i = j + 1; i < n; i++) {
            double s = M[i * n + j];
            for (k = 0; k < j; k++) s -= L[i * n + k] * L[j * n + k];
            L[i * n + j] = s / L[j * n + j];
        }
    }
    for (i = 0; i < n; i++) {
        double s = tau[i] - h[i];
        for (k = 0; k < i; k++) s -= L[i * n + k] * z[k];
        z[i] = s / L[i * n + i];
    }
    for (i = n - 1; i >= 0; i--) {
        double s = z[i];
        for (k = i + 1; k < n; k++) s -= L[k * n + i] * qdd[k];
        qdd[i] = s / L[i * n + i];
    }
    return 0;
}

void rnea_batch(const double *model, long N, const double *Q, const double *QD,
                const double *QDD, double *TAU, int grav, int drv) {
    int n = (int)model[0];
    long s;
    for (s = 0; s < N; s++) rnea_one(model, Q + s * n, QD + s * n, QDD + s * n, TAU + s * n, grav, drv);
}

void mass_batch(const double *model, long N, const double *Q, double *M) {
    int n = (int)model[0];
    long s;
    for (s = 0; s < N; s++) mass_one(model, Q + s * n, M + s * n * n);
}

/* The regressor row block of one sample: Ys (n, n*P) zeroed and filled; P = 10 + the drive
 * terms present, ident[k] marks link→joint maps that are the identity. */
static void regressor_one(const double *model, const double *A, const int *present,
                          const int *ident, int n, int P, const double *q, const double *qd,
                          const double *qdd, double *Ys) {
    int d, i, k, c, r;
    kin_t K;
    double YJ[10];
    kinematics(model, q, qd, qdd, 1, &K);
    memset(Ys, 0, sizeof(double) * (size_t)n * n * P);
    for (k = 0; k < n; k++) {
        const double *w = K.w[k], *dw = K.dw[k], *acc = K.acc[k];
        double F[3][10], Nn[3][10];
        memset(F, 0, sizeof F);
        memset(Nn, 0, sizeof Nn);
        for (c = 0; c < 3; c++) F[c][0] = acc[c];
        for (c = 0; c < 3; c++) {
            double e[3] = {0, 0, 0}, t1[3], t2[3], t3[3];
            e[c] = 1.0;
            cross(dw, e, t1);
            cross(w, e, t2);
            cross(w, t2, t2);
            cross(e, acc, t3);
            for (r = 0; r < 3; r++) { F[r][1 + c] = t1[r] + t2[r]; Nn[r][1 + c] = t3[r]; }
        }
        {   /* I dw + w × (I w), I v = L(v) [XX XY XZ YY YZ ZZ] */
            double Ld[3][6] = {{dw[0], dw[1], dw[2], 0, 0, 0}, {0, dw[0], 0, dw[1], dw[2], 0}, {0, 0, dw[0], 0, dw[1], dw[2]}};
            double Lw[3][6] = {{w[0], w[1], w[2], 0, 0, 0}, {0, w[0], 0, w[1], w[2], 0}, {0, 0, w[0], 0, w[1], w[2]}};
            for (c = 0; c < 6; c++) {
                double col[3] = {Lw[0][c], Lw[1][c], Lw[2][c]}, t[3];
                cross(w, col, t);
                for (r = 0; r < 3; r++) Nn[r][4 + c] = Ld[r][c] + t[r];
            }
        }
        for (i = k; i >= 0; i = (int)model[4 + i * JS + 35]) {
            const double *J = model + 4 + i * JS, *a = J + 13;
            double (*S)[10] = J[0] == 0.0 ? Nn : F;
            for (c = 0; c < 10; c++) YJ[c] = a[0] * S[0][c] + a[1] * S[1][c] + a[2] * S[2][c];
            {   /* link-frame parameters: row of Y_J times A_k (skipped when A_k = I) */
                const double *Ak = A + k * 100;
                double *row = Ys + (long)i * n * P + k * P;
                if (ident[k]) { memcpy(row, YJ, sizeof YJ); }
                else for (c = 0; c < 10; c++) {
                    double acc2 = 0;
                    for (r = 0; r < 10; r++) acc2 += YJ[r] * Ak[r * 10 + c];
                    row[c] = acc2;
                }
            }
            if (model[4 + i * JS + 35] >= 0) {  /* to the parent frame; F is zero beyond
                                                  column 3 (m, m·c) */
                const double *R = K.R[i], *p = K.p[i];
                for (c = 0; c < 10; c++) {
                    double nn[3] = {Nn[0][c], Nn[1][c], Nn[2][c]};
                    mv(R, nn, nn);
                    if (c < 4) {
                        double f[3] = {F[0][c], F[1][c], F[2][c]}, t[3];
                        mv(R, f, f);
                        cross(p, f, t);
                        for (r = 0; r < 3; r++) { F[r][c] = f[r]; nn[r] += t[r]; }
                    }
                    for (r = 0; r < 3; r++) Nn[r][c] = nn[r];
                }
            }
        }
    }
    for (i = 0; i < n; i++) {
        double v = qd[i], acc3 = qdd[i], col[8];
        col[0] = acc3; col[1] = v; col[2] = sgn(v); col[3] = v > 0 ? v : 0.0;
        col[4] = v < 0 ? v : 0.0; col[5] = v > 0; col[6] = -(double)(v < 0); col[7] = 1.0;
        for (d = 0, c = 10; d < 8; d++)
            if (present[d]) Ys[(long)i * n * P + i * P + c++] = col[d];
    }
}

static void regressor_setup(const double *A, const double *mask, int n, int *present,
                            int *ident, int *P) {
    int d, k, r;
    *P = 10;
    for (d = 0; d < 8; d++) { present[d] = mask[d] != 0.0; *P += present[d]; }
    for (k = 0; k < n; k++) {
        ident[k] = 1;
        for (r = 0; r < 100; r++)
            if (A[k * 100 + r] != (r % 11 == 0 ? 1.0 : 0.0)) { ident[k] = 0; break; }
    }
}

/* Regressor rows of N samples: Y (N, n, n*P), P = 10 + n_drive; A (n, 10, 10) link→joint maps;
 * mask (8) marks the drive terms present (their columns follow the 10 standard ones). */
void regressor_batch(const double *model, const double *A, const double *mask, long N,
                     const double *Q, const double *QD, const double *QDD, double *Y) {
    int n = (int)model[0], P, present[8], ident[MAXJ];
    long s;
    regressor_setup(A, mask, n, present, ident, &P);
    for (s = 0; s < N; s++)
        regressor_one(model, A, present, ident, n, P, Q + s * n, QD + s * n, QDD + s * n,
                      Y + s * (long)n * n * P);
}

/* The columns ``cols`` (ncols of the n*P) of the regressor rows of N samples, written to W:
 * sample s, joint i, column k at W[s * stride + i * ncols + k] (stride >= n * ncols), so that
 * a caller's wider array of rows takes them in place. Returns -1 when scratch memory fails. */
int regressor_columns_batch(const double *model, const double *A, const double *mask,
                            const long *cols, long ncols, long N, const double *Q,
                            const double *QD, const double *QDD, double *W, long stride) {
    int n = (int)model[0], P, present[8], ident[MAXJ], i;
    long s, k;
    double *Ys;
    regressor_setup(A, mask, n, present, ident, &P);
    Ys = (double *)malloc(sizeof(double) * (size_t)n * n * P);
    if (Ys == NULL) return -1;
    for (s = 0; s < N; s++) {
        double *row = W + s * stride;
        regressor_one(model, A, present, ident, n, P, Q + s * n, QD + s * n, QDD + s * n, Ys);
        for (i = 0; i < n; i++) {
            const double *src = Ys + (long)i * n * P;
            for (k = 0; k < ncols; k++) row[i * ncols + k] = src[cols[k]];
        }
    }
    free(Ys);
    return 0;
}

/* PD closed loop ẏ = [q̇, M⁻¹(Kp (r − q) − Kd q̇ − h)], reference: cubic spline or r_now.
 * ctx = [t, y (2n), ẏ (2n), t0, h, n_int, use_spline, Kp (n), Kd (n), r_first (n), r_last (n),
 *        r_now (n), coefficients (n_int × n × 4)] */
int pd_rhs(double *ctx, const double *model) {
    int n = (int)model[0], j;
    const double t = ctx[0], *y = ctx + 1;
    double *dy = ctx + 1 + 2 * n;
    const double *S = ctx + 1 + 4 * n;
    const double t0 = S[0], hk = S[1];
    const long n_int = (long)S[2];
    const int use_spline = S[3] != 0.0;
    const double *KP = S + 4, *KD = KP + n, *RF = KD + n, *RL = RF + n, *RN = RL + n, *COEF = RN + n;
    double r[MAXJ], tau[MAXJ];
    if (!use_spline) { for (j = 0; j < n; j++) r[j] = RN[j]; }
    else if (n_int == 0 || t <= t0) { for (j = 0; j < n; j++) r[j] = RF[j]; }
    else if (t >= t0 + n_int * hk) { for (j = 0; j < n; j++) r[j] = RL[j]; }
    else {
        long iv = (long)((t - t0) / hk);
        if (iv >= n_int) iv = n_int - 1;
        const double s = t - (t0 + iv * hk);
        for (j = 0; j < n; j++) {
            const double *cc = COEF + (iv * n + j) * 4;
            r[j] = ((cc[0] * s + cc[1]) * s + cc[2]) * s + cc[3];
        }
    }
    for (j = 0; j < n; j++) tau[j] = KP[j] * (r[j] - y[j]) - KD[j] * y[n + j];
    for (j = 0; j < n; j++) dy[j] = y[n + j];
    return forward_one(model, y, y + n, tau, dy + n);
}
