/* The Kalman and IMM arithmetic of gazed's filter banks, compiled.

   Python drives it from gazed/estimation/kalman.py, which documents every entry point; the
   equations are those of seed 000 §4.1 and §5 (the ground models CSD, CS, CD and the IMM)
   and seed 003 eqs. (4)-(10) (the linear Kalman filter), with the errata of DESIGN §10.

   A bank holds N tracks of M models of an n-state filter, C-contiguous float64:
       x (N, M, n), P (N, M, n, n), mu (N, M).
   `rows` (K,) int64 selects the tracks a call works on (None: all N, in order); every other
   per-row array (dt, z, R, the innovation terms) has K rows, in the order of `rows`.

   Why C: one track's step is a few thousand flops on 6x6 matrices. NumPy pays a fixed
   overhead per call however small its operands, and an IMM step needs hundreds of calls;
   here the step is one call, and a batch of tracks is a loop that stays in cache.

   Heading: with `angle` >= 0 that state component is an angle, averaged as one in mixing and
   combination (its differences wrapped to (-π, π]) and wrapped after an update. */

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

#define NMAX 8 /* state dimension */
#define MMAX 4 /* measurement dimension */
#define KMAX 8 /* models in a bank */

/* the ground state [X, Y, s, θ, ṡ, θ̇] (gazed/estimation/ground_models.py) */
enum { IX, IY, IS, ITH, ISD, ITD, GROUND_DIM };
/* a ground model's parameters: its two switches and its two noise variances */
enum { G_ACCEL, G_TURNS, G_Q_SPEED, G_Q_HEADING, GROUND_PARAMETERS };
/* below this |u| = |ωT| the series of A(u), B(u) and their derivatives replace the closed forms */
#define SERIES_LIMIT 1e-3
#define LOG_2PI 1.8378770664093453
/* a loop over at least this many tracks runs without the GIL (zenoh's threads go on meanwhile) */
#define THREADS_FROM_ROWS 64
#define RUN(K, call)                                                                                         \
    do {                                                                                                     \
        if ((K) >= THREADS_FROM_ROWS) {                                                                      \
            Py_BEGIN_ALLOW_THREADS call;                                                                     \
            Py_END_ALLOW_THREADS                                                                             \
        } else {                                                                                             \
            call;                                                                                            \
        }                                                                                                    \
    } while (0)

/* ------------------------------------------------------------------------- small algebra */

/* a + 2π ⌊(π - a) / 2π⌋: wrapped to (-π, π], -π -> π exactly */
static double wrap(double a) { return a + 2.0 * M_PI * floor((M_PI - a) / (2.0 * M_PI)); }

/* C = A B, A (r, k), B (k, c) */
static void matmul(int r, int k, int c, const double *A, const double *B, double *C) {
    for (int i = 0; i < r; i++)
        for (int j = 0; j < c; j++) {
            double sum = 0.0;
            for (int l = 0; l < k; l++) sum += A[i * k + l] * B[l * c + j];
            C[i * c + j] = sum;
        }
}

/* C = A Bᵀ, A (r, k), B (c, k) */
static void matmul_t(int r, int k, int c, const double *A, const double *B, double *C) {
    for (int i = 0; i < r; i++)
        for (int j = 0; j < c; j++) {
            double sum = 0.0;
            for (int l = 0; l < k; l++) sum += A[i * k + l] * B[j * k + l];
            C[i * c + j] = sum;
        }
}

/* A <- (A + Aᵀ) / 2, A (n, n) */
static void symmetrise(int n, double *A) {
    for (int i = 0; i < n; i++)
        for (int j = i + 1; j < n; j++) A[i * n + j] = A[j * n + i] = 0.5 * (A[i * n + j] + A[j * n + i]);
}

/* out = F P Fᵀ + Q, symmetrised (seed 000 §4.1, seed 003 eq. 7); Q may be NULL */
static void propagate_covariance(int n, const double *F, const double *P, const double *Q, double *out) {
    double FP[NMAX * NMAX];
    matmul(n, n, n, F, P, FP);
    matmul_t(n, n, n, FP, F, out);
    if (Q)
        for (int i = 0; i < n * n; i++) out[i] += Q[i];
    symmetrise(n, out);
}

/* S⁻¹ and log det S of a symmetric S (m, m) by Cholesky; 0 if S is not positive definite */
static int inverse_and_log_det(int m, const double *S, double *S_inv, double *log_det) {
    double L[MMAX * MMAX] = {0}, L_inv[MMAX * MMAX] = {0};
    double sum_log = 0.0;
    for (int j = 0; j < m; j++) {
        double d = S[j * m + j];
        for (int k = 0; k < j; k++) d -= L[j * m + k] * L[j * m + k];
        if (!(d > 0.0) || !isfinite(d)) return 0;
        double l = sqrt(d);
        L[j * m + j] = l;
        sum_log += log(l);
        for (int i = j + 1; i < m; i++) {
            double v = S[i * m + j];
            for (int k = 0; k < j; k++) v -= L[i * m + k] * L[j * m + k];
            L[i * m + j] = v / l;
        }
    }
    for (int j = 0; j < m; j++) { /* L⁻¹, lower triangular, by forward substitution */
        L_inv[j * m + j] = 1.0 / L[j * m + j];
        for (int i = j + 1; i < m; i++) {
            double v = 0.0;
            for (int k = j; k < i; k++) v -= L[i * m + k] * L_inv[k * m + j];
            L_inv[i * m + j] = v / L[i * m + i];
        }
    }
    for (int i = 0; i < m; i++) /* S⁻¹ = L⁻ᵀ L⁻¹ */
        for (int j = 0; j <= i; j++) {
            double v = 0.0;
            for (int k = i; k < m; k++) v += L_inv[k * m + i] * L_inv[k * m + j];
            S_inv[i * m + j] = S_inv[j * m + i] = v;
        }
    *log_det = 2.0 * sum_log;
    return 1;
}

/* ------------------------------------------------------------------- the ground models */

/* A = sin u / u, B = (1 - cos u) / u and their derivatives A' = (cos u - A) / u,
   B' = (sin u - B) / u; below SERIES_LIMIT their series (the next terms < 1e-14) */
static void turn_terms(double u, double *A, double *B, double *A1, double *B1) {
    if (fabs(u) < SERIES_LIMIT) {
        double u2 = u * u;
        *A = 1.0 - u2 / 6.0;
        *B = u * (0.5 - u2 / 24.0);
        *A1 = u * (u2 / 30.0 - 1.0 / 3.0);
        *B1 = 0.5 - u2 / 8.0;
        return;
    }
    double sin_u = sin(u), cos_u = cos(u);
    *A = sin_u / u;
    *B = (1.0 - cos_u) / u;
    *A1 = (cos_u - *A) / u;
    *B1 = (sin_u - *B) / u;
}

/* noise gains T^k/k! for k = (2, 1, 0) + order, order 0 (ṡ, θ̇) or 1 (s̈ for CD, θ̈ for CS) */
static void noise_gains(double order, double T, double g[3]) {
    double other = 1.0 - order, half_T2 = 0.5 * T * T;
    g[0] = half_T2 * (other + order * T / 3.0);
    g[1] = T * (other + order * 0.5 * T);
    g[2] = other + order * T;
}

/* One ground model over T (seed 000 §4.1.2-4.1.4 with the errata), written once for all three
   with the switches `accel` (CD propagates ṡ) and `turns` (CS propagates θ̇):
       d = sT + aT²/2 (a = ṡ·accel),  u = ωT (ω = θ̇·turns)
       X' = X + d (cos θ A(u) - sin θ B(u)),  Y' = Y + d (sin θ A(u) + cos θ B(u))
       s' = s + aT,  θ' = θ + u (wrapped),  ṡ' = a,  θ̇' = ω
   A rate a model does not estimate is, as §4.1.2 says, a zero-mean noise term: predicted 0.
   F = ∇f (6, 6); Q = G diag(q_speed, q_heading) Gᵀ with G the first-order gains of the two
   noise inputs held constant over T (§4.1.2). F and Q may be NULL. */
static void ground_motion(const double *x, double T, const double *model, double *xn, double *F, double *Q) {
    double accel = model[G_ACCEL], turns = model[G_TURNS];
    double s = x[IS], th = x[ITH];
    double a = x[ISD] * accel, w = x[ITD] * turns, u = w * T, half_T2 = 0.5 * T * T;
    double d = s * T + a * half_T2;
    double A, B, A1, B1;
    turn_terms(u, &A, &B, &A1, &B1);
    double c = cos(th), sn = sin(th);
    /* (A, B) and (A', B') rotated by θ: the displacement per unit of d and its derivative by u */
    double e0x = c * A - sn * B, e0y = sn * A + c * B;
    double e1x = c * A1 - sn * B1, e1y = sn * A1 + c * B1;
    xn[IX] = x[IX] + d * e0x;
    xn[IY] = x[IY] + d * e0y;
    xn[IS] = s + a * T;
    xn[ITH] = wrap(th + u);
    xn[ISD] = a;
    xn[ITD] = w;
    if (F) {
        memset(F, 0, sizeof(double) * GROUND_DIM * GROUND_DIM);
#define F_(i, j) F[(i) * GROUND_DIM + (j)]
        F_(IX, IX) = F_(IY, IY) = F_(IS, IS) = F_(ITH, ITH) = 1.0;
        F_(ISD, ISD) = accel;
        F_(ITD, ITD) = turns;
        F_(IX, IS) = e0x * T;
        F_(IY, IS) = e0y * T;
        F_(IX, ITH) = -d * e0y;
        F_(IY, ITH) = d * e0x;
        F_(IX, ISD) = accel * half_T2 * e0x;
        F_(IY, ISD) = accel * half_T2 * e0y;
        F_(IX, ITD) = turns * d * T * e1x;
        F_(IY, ITD) = turns * d * T * e1y;
        F_(IS, ISD) = accel * T;
        F_(ITH, ITD) = turns * T;
#undef F_
    }
    if (Q) {
        double speed[3], turn[3];
        noise_gains(accel, T, speed);
        noise_gains(turns, T, turn);
        /* the speed noise acts along θ, the heading noise across it, times s */
        double g_speed[GROUND_DIM] = {c * speed[0], sn * speed[0], speed[1], 0.0, speed[2], 0.0};
        double s_turn = s * turn[0];
        double g_heading[GROUND_DIM] = {-sn * s_turn, c * s_turn, 0.0, turn[1], 0.0, turn[2]};
        for (int i = 0; i < GROUND_DIM; i++)
            for (int j = 0; j < GROUND_DIM; j++)
                Q[i * GROUND_DIM + j] = model[G_Q_SPEED] * g_speed[i] * g_speed[j] +
                                        model[G_Q_HEADING] * g_heading[i] * g_heading[j];
    }
}

/* h(x) = (X, Y, s cos θ, s sin θ) (errata of §4.1.1) or (X, Y), and H = ∇h (m, 6) */
static void ground_measure(int m, const double *x, double *h, double *H) {
    memset(H, 0, sizeof(double) * m * GROUND_DIM);
    h[0] = x[IX];
    h[1] = x[IY];
    H[0 * GROUND_DIM + IX] = H[1 * GROUND_DIM + IY] = 1.0;
    if (m == 4) {
        double c = cos(x[ITH]), sn = sin(x[ITH]), s = x[IS];
        h[2] = s * c;
        h[3] = s * sn;
        H[2 * GROUND_DIM + IS] = c;
        H[3 * GROUND_DIM + IS] = sn;
        H[2 * GROUND_DIM + ITH] = -s * sn;
        H[3 * GROUND_DIM + ITH] = s * c;
    }
}

/* (s, θ, ṡ) -> (-s, θ + π, -ṡ) when s < 0 (the same motion), P -> D P D, D = diag(1, 1, -1, 1, -1, 1) */
static int canonical(double *x, double *P) {
    if (!(x[IS] < 0.0)) return 0;
    static const double D[GROUND_DIM] = {1.0, 1.0, -1.0, 1.0, -1.0, 1.0};
    x[IS] = -x[IS];
    x[ISD] = -x[ISD];
    x[ITH] = wrap(x[ITH] + M_PI);
    for (int i = 0; i < GROUND_DIM; i++)
        for (int j = 0; j < GROUND_DIM; j++) P[i * GROUND_DIM + j] *= D[i] * D[j];
    return 1;
}

/* ----------------------------------------------------------------------------- the IMM */

/* §5 step 1 for one track. J[i, j] = P(model j next | model i now):
       c̄_j = Σ_i J_ij μ_i,  ω_ij = J_ij μ_i / c̄_j,  x0_j = Σ_i ω_ij x_i
       P0_j = Σ_i ω_ij (P_i + (x_i - x0_j)(x_i - x0_j)ᵀ)
   The angle of model j is mixed about its own: x0_j = θ_j + Σ_i ω_ij wrap(θ_i - θ_j), left
   unwrapped (the motion model that follows wraps it). A model nobody can switch to (c̄_j = 0)
   keeps its own state. */
static void mix_track(int M, int n, const double *mu, const double *J, const double *x, const double *P,
                      int angle, double *cbar, double *x0, double *P0) {
    for (int j = 0; j < M; j++) {
        double c = 0.0;
        for (int i = 0; i < M; i++) c += mu[i] * J[i * M + j];
        cbar[j] = c;
        double *xj = x0 + j * n, *Pj = P0 + j * n * n;
        if (!(c > 0.0)) {
            memcpy(xj, x + j * n, sizeof(double) * n);
            memcpy(Pj, P + j * n * n, sizeof(double) * n * n);
            continue;
        }
        double w[KMAX], d[KMAX], spread = 0.0;
        for (int i = 0; i < M; i++) w[i] = J[i * M + j] * mu[i] / c;
        for (int k = 0; k < n; k++) {
            double v = 0.0;
            for (int i = 0; i < M; i++) v += w[i] * x[i * n + k];
            xj[k] = v;
        }
        if (angle >= 0) {
            double own = x[j * n + angle];
            for (int i = 0; i < M; i++) {
                d[i] = wrap(x[i * n + angle] - own);
                spread += w[i] * d[i];
            }
            xj[angle] = own + spread;
        }
        memset(Pj, 0, sizeof(double) * n * n);
        for (int i = 0; i < M; i++) {
            double D[NMAX];
            for (int k = 0; k < n; k++) D[k] = x[i * n + k] - xj[k];
            if (angle >= 0) D[angle] = wrap(d[i] - spread);
            const double *Pi = P + i * n * n;
            for (int k = 0; k < n; k++)
                for (int l = 0; l < n; l++) Pj[k * n + l] += w[i] * (Pi[k * n + l] + D[k] * D[l]);
        }
    }
}

/* §5 step 4 for one track: x = Σ_j μ_j x_j, P = Σ_j μ_j (P_j + (x_j - x)(x_j - x)ᵀ); the angle
   averaged about the most likely model's, so that π-ε and -π+ε combine to π */
static void combine_track(int M, int n, const double *mu, const double *x, const double *P, int angle,
                          double *xc, double *Pc) {
    double d[KMAX], spread = 0.0, reference = 0.0;
    for (int k = 0; k < n; k++) {
        double v = 0.0;
        for (int j = 0; j < M; j++) v += mu[j] * x[j * n + k];
        xc[k] = v;
    }
    if (angle >= 0) {
        int best = 0;
        for (int j = 1; j < M; j++)
            if (mu[j] > mu[best]) best = j;
        reference = x[best * n + angle];
        for (int j = 0; j < M; j++) {
            d[j] = wrap(x[j * n + angle] - reference);
            spread += mu[j] * d[j];
        }
        xc[angle] = wrap(reference + spread);
    }
    memset(Pc, 0, sizeof(double) * n * n);
    for (int j = 0; j < M; j++) {
        double D[NMAX];
        for (int k = 0; k < n; k++) D[k] = x[j * n + k] - xc[k];
        if (angle >= 0) D[angle] = wrap(d[j] - spread);
        const double *Pj = P + j * n * n;
        for (int k = 0; k < n; k++)
            for (int l = 0; l < n; l++) Pc[k * n + l] += mu[j] * (Pj[k * n + l] + D[k] * D[l]);
    }
}

/* §5 step 3: μ_j ∝ prior_j exp(ℓ_j), scaled by the largest likelihood; if that model has prior 0
   (a switching matrix with zeros) the sum underflows, and it is taken in logarithms instead */
static void posterior_track(int M, const double *prior, const double *log_likelihood, double *mu) {
    double top = -INFINITY, total = 0.0;
    for (int j = 0; j < M; j++)
        if (log_likelihood[j] > top) top = log_likelihood[j];
    for (int j = 0; j < M; j++) total += (mu[j] = prior[j] * exp(log_likelihood[j] - top));
    if (!(total > 0.0) || !isfinite(total)) {
        double log_w[KMAX];
        top = -INFINITY;
        for (int j = 0; j < M; j++) {
            log_w[j] = (prior[j] > 0.0 ? log(prior[j]) : -INFINITY) + log_likelihood[j];
            if (log_w[j] > top) top = log_w[j];
        }
        total = 0.0;
        for (int j = 0; j < M; j++) total += (mu[j] = exp(log_w[j] - top));
    }
    for (int j = 0; j < M; j++) mu[j] /= total;
}

/* ------------------------------------------------------------------- the filter steps */

/* the bank of one call: sizes, the arrays of the tracks, and how its models move and measure */
typedef struct {
    Py_ssize_t N, K;
    int M, n;
    double *x, *P, *mu;
    const long long *rows; /* NULL: all tracks in order */
    const double *ground;  /* (M, GROUND_PARAMETERS) ground models, or NULL: linear */
    const double *J;       /* (M, M) mixing, or NULL: independent models */
    const double *q_scale; /* (K,) each selected track's factor on its ground models' Q, or NULL: 1 */
    int angle;
} Bank;

static Py_ssize_t track_of(const Bank *b, Py_ssize_t k) { return b->rows ? (Py_ssize_t)b->rows[k] : k; }

/* a ground model's Q times the selected track k's factor λ (the noise each track learns,
   noise_adaptation.py), if the bank has factors */
static void scale_noise(const Bank *b, Py_ssize_t k, int n, double *Q) {
    if (!b->q_scale) return;
    for (int i = 0; i < n * n; i++) Q[i] *= b->q_scale[k];
}

/* mix (if J), then each model over dt: x' = f(x0) (ground) or F x0, P' = F P0 Fᵀ + λQ; μ <- c̄.
   F, Q (K, M, n, n) are the linear models' matrices (NULL for ground models) */
static void predict_rows(const Bank *b, const double *dt, const double *F_lin, const double *Q_lin) {
    int M = b->M, n = b->n, nn = n * n;
    for (Py_ssize_t k = 0; k < b->K; k++) {
        Py_ssize_t r = track_of(b, k);
        double *x = b->x + r * M * n, *P = b->P + r * M * nn;
        double x0[KMAX * NMAX], P0[KMAX * NMAX * NMAX], cbar[KMAX];
        if (b->J) {
            mix_track(M, n, b->mu + r * M, b->J, x, P, b->angle, cbar, x0, P0);
            memcpy(b->mu + r * M, cbar, sizeof(double) * M);
        } else {
            memcpy(x0, x, sizeof(double) * M * n);
            memcpy(P0, P, sizeof(double) * M * nn);
        }
        for (int j = 0; j < M; j++) {
            double F[NMAX * NMAX], Q[NMAX * NMAX];
            const double *Fj = F, *Qj = Q;
            if (b->ground) {
                ground_motion(x0 + j * n, dt[k], b->ground + j * GROUND_PARAMETERS, x + j * n, F, Q);
                scale_noise(b, k, n, Q);
            } else {
                Fj = F_lin + (k * M + j) * nn;
                Qj = Q_lin + (k * M + j) * nn;
                matmul(n, n, 1, Fj, x0 + j * n, x + j * n);
            }
            propagate_covariance(n, Fj, P0 + j * nn, Qj, P + j * nn);
        }
    }
}

/* the measurement of model state x: ground h(x) and ∇h, or the linear H (m, n) */
static void measure_state(const Bank *b, int m, const double *H_lin, const double *x, double *h, double *H) {
    if (b->ground) {
        ground_measure(m, x, h, H);
        return;
    }
    memcpy(H, H_lin, sizeof(double) * m * b->n);
    matmul(m, b->n, 1, H, x, h);
}

/* ν = z - h(x), S = H P Hᵀ + R, K = P Hᵀ S⁻¹, NIS = νᵀ S⁻¹ ν, ℓ = log N(ν; 0, S)
   (seed 003 eqs. 5, 9, 10; seed 000 §5 step 3). S not positive definite: NIS = inf, ℓ = -inf,
   K = 0 (no gate accepts it). Outputs per row and model: y (m), S (m, m), K (n, m), nis, ℓ. */
static void innovate_rows(const Bank *b, int m, const double *z, const double *R, const double *H_lin,
                          double *y, double *S, double *Kg, double *nis, double *log_likelihood) {
    int M = b->M, n = b->n;
    for (Py_ssize_t k = 0; k < b->K; k++) {
        Py_ssize_t r = track_of(b, k);
        for (int j = 0; j < M; j++) {
            Py_ssize_t o = k * M + j;
            const double *x = b->x + (r * M + j) * n, *P = b->P + (r * M + j) * n * n;
            double h[MMAX], H[MMAX * NMAX], PHt[NMAX * MMAX], S_inv[MMAX * MMAX], log_det;
            double *yo = y + o * m, *So = S + o * m * m, *Ko = Kg + o * n * m;
            measure_state(b, m, H_lin, x, h, H);
            for (int i = 0; i < m; i++) yo[i] = z[k * m + i] - h[i];
            matmul_t(n, n, m, P, H, PHt); /* P Hᵀ (P symmetric) */
            matmul(m, n, m, H, PHt, So);
            for (int i = 0; i < m * m; i++) So[i] += R[k * m * m + i];
            symmetrise(m, So);
            if (!inverse_and_log_det(m, So, S_inv, &log_det)) {
                nis[o] = INFINITY;
                log_likelihood[o] = -INFINITY;
                memset(Ko, 0, sizeof(double) * n * m);
                continue;
            }
            matmul(n, m, m, PHt, S_inv, Ko);
            double q = 0.0;
            for (int i = 0; i < m; i++)
                for (int l = 0; l < m; l++) q += yo[i] * S_inv[i * m + l] * yo[l];
            nis[o] = q;
            log_likelihood[o] = -0.5 * (q + log_det + m * LOG_2PI);
        }
    }
}

/* x <- x + K ν, P <- (I - K H) P (I - K H)ᵀ + K R Kᵀ (Joseph form of seed 003 eq. 8: symmetric
   positive semi-definite whatever the gain), the angle wrapped; then μ from ℓ (if mu) and a
   negative speed made positive (ground models). H is re-evaluated at the predicted state,
   which `innovate` saw. */
static Py_ssize_t correct_rows(const Bank *b, int m, const double *y, const double *Kg, const double *R,
                               const double *H_lin, const double *log_likelihood) {
    int M = b->M, n = b->n;
    Py_ssize_t flipped = 0;
    for (Py_ssize_t k = 0; k < b->K; k++) {
        Py_ssize_t r = track_of(b, k);
        for (int j = 0; j < M; j++) {
            Py_ssize_t o = k * M + j;
            double *x = b->x + (r * M + j) * n, *P = b->P + (r * M + j) * n * n;
            const double *K = Kg + o * n * m, *yo = y + o * m;
            double h[MMAX], H[MMAX * NMAX], A[NMAX * NMAX], AP[NMAX * NMAX], KR[NMAX * MMAX];
            measure_state(b, m, H_lin, x, h, H);
            matmul(n, m, n, K, H, A); /* A = I - K H */
            for (int i = 0; i < n * n; i++) A[i] = -A[i];
            for (int i = 0; i < n; i++) A[i * n + i] += 1.0;
            for (int i = 0; i < n; i++)
                for (int l = 0; l < m; l++) x[i] += K[i * m + l] * yo[l];
            if (b->angle >= 0) x[b->angle] = wrap(x[b->angle]);
            matmul(n, n, n, A, P, AP);
            matmul_t(n, n, n, AP, A, P);
            matmul(n, m, m, K, R + k * m * m, KR);
            for (int i = 0; i < n; i++)
                for (int l = 0; l < n; l++) {
                    double v = 0.0;
                    for (int t = 0; t < m; t++) v += KR[i * m + t] * K[l * m + t];
                    P[i * n + l] += v;
                }
            symmetrise(n, P);
        }
        if (b->mu) {
            double prior[KMAX];
            memcpy(prior, b->mu + r * M, sizeof(double) * M);
            posterior_track(M, prior, log_likelihood + k * M, b->mu + r * M);
        }
        if (b->ground)
            for (int j = 0; j < M; j++)
                flipped += canonical(b->x + (r * M + j) * n, b->P + (r * M + j) * n * n);
    }
    return flipped;
}

/* each ground model dt ahead without mixing (dt = 0: as it is), mapped to [X, Y, Ẋ, Ẏ] through
   h and its Jacobian G, then the μ-weighted mixture moments: mean (K, 4), cov (K, 4, 4) */
static void forecast_rows(const Bank *b, const double *dt, double *mean, double *cov) {
    int M = b->M, n = b->n;
    for (Py_ssize_t k = 0; k < b->K; k++) {
        Py_ssize_t r = track_of(b, k);
        double g[KMAX * MMAX], C[KMAX * MMAX * MMAX];
        for (int j = 0; j < M; j++) {
            const double *x = b->x + (r * M + j) * n, *P = b->P + (r * M + j) * n * n;
            double xn[NMAX], F[NMAX * NMAX], Q[NMAX * NMAX], Pn[NMAX * NMAX], G[MMAX * NMAX], GP[MMAX * NMAX];
            if (dt[k] > 0.0) {
                ground_motion(x, dt[k], b->ground + j * GROUND_PARAMETERS, xn, F, Q);
                scale_noise(b, k, n, Q);
                propagate_covariance(n, F, P, Q, Pn);
                x = xn;
                P = Pn;
            }
            ground_measure(MMAX, x, g + j * MMAX, G);
            matmul(MMAX, n, n, G, P, GP);
            matmul_t(MMAX, n, MMAX, GP, G, C + j * MMAX * MMAX);
        }
        combine_track(M, MMAX, b->mu + r * M, g, C, -1, mean + k * MMAX, cov + k * MMAX * MMAX);
    }
}

/* ------------------------------------------------------------------------ Python glue */

/* The buffers of one call, released together. */
typedef struct {
    Py_buffer views[16];
    int count;
} Buffers;

static void release(Buffers *bs) {
    for (int i = 0; i < bs->count; i++) PyBuffer_Release(&bs->views[i]);
    bs->count = 0;
}

/* The data of `obj`, a C-contiguous buffer of `count` float64 ('d') or int64 ('q', 'l')
   items, writable if asked; NULL (with `optional`) for None. Sets *ok = 0 and an exception
   otherwise. */
static void *data_of(Buffers *bs, PyObject *obj, const char *name, Py_ssize_t count, int writable, int integer,
                     int optional, int *ok) {
    if (!*ok) return NULL;
    if (obj == Py_None && optional) return NULL;
    Py_buffer *v = &bs->views[bs->count];
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, v, flags) < 0) {
        *ok = 0;
        return NULL;
    }
    bs->count++;
    const char *f = v->format ? v->format : "B";
    if (*f == '<' || *f == '=' || *f == '@') f++;
    int format_ok = integer ? (f[0] == 'q' || f[0] == 'l') && f[1] == 0 : f[0] == 'd' && f[1] == 0;
    if (!format_ok || v->itemsize != 8 || v->len != count * 8) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd contiguous %s, got %zd bytes of '%s'", name, count,
                     integer ? "int64" : "float64", v->len, f);
        *ok = 0;
        return NULL;
    }
    return v->buf;
}

/* no product of a count of tracks (or states) and the largest per-row size overflows */
#define MAX_ROWS (PY_SSIZE_T_MAX / (8 * KMAX * NMAX * NMAX * 8))

/* N tracks (or states) and K rows of M models, n states, m measured; the angle's index
   (-1: none) within the state */
static int check_sizes(Py_ssize_t N, Py_ssize_t K, int M, int n, int m, int angle) {
    if (N < 0 || N > MAX_ROWS || K < 0 || K > MAX_ROWS || M < 1 || M > KMAX || n < 1 || n > NMAX || m < 0 ||
        m > MMAX) {
        PyErr_Format(PyExc_ValueError, "bank sizes out of range: N=%zd K=%zd M=%d n=%d m=%d", N, K, M, n, m);
        return 0;
    }
    if (angle < -1 || angle >= n) {
        PyErr_Format(PyExc_ValueError, "angle index %d outside the %d-state (-1: none)", angle, n);
        return 0;
    }
    return 1;
}

/* intervals a step can take: finite and >= 0 */
static int check_intervals(const double *dt, Py_ssize_t K) {
    for (Py_ssize_t k = 0; k < K; k++)
        if (!(dt[k] >= 0.0) || !isfinite(dt[k])) {
            PyErr_Format(PyExc_ValueError, "interval %zd is not a finite dt >= 0", k);
            return 0;
        }
    return 1;
}

/* a factor on Q must be finite and >= 0 */
static int check_scales(const double *q_scale, Py_ssize_t K) {
    for (Py_ssize_t k = 0; q_scale && k < K; k++)
        if (!(q_scale[k] >= 0.0) || !isfinite(q_scale[k])) {
            PyErr_Format(PyExc_ValueError, "process-noise scale %zd is not a finite number >= 0", k);
            return 0;
        }
    return 1;
}

/* rows (K,) must name tracks in [0, N) */
static int check_rows(const Bank *b) {
    if (!b->rows) {
        if (b->K != b->N) {
            PyErr_SetString(PyExc_ValueError, "rows=None means every track: K must equal N");
            return 0;
        }
        return 1;
    }
    for (Py_ssize_t k = 0; k < b->K; k++)
        if (b->rows[k] < 0 || b->rows[k] >= b->N) {
            PyErr_Format(PyExc_IndexError, "row %lld outside the %zd tracks", b->rows[k], b->N);
            return 0;
        }
    return 1;
}

/* the bank's own arrays: x, P, mu (optional), rows (optional, K of them) */
static int bank_of(Buffers *bs, Bank *b, PyObject *x, PyObject *P, PyObject *mu, PyObject *rows, Py_ssize_t K) {
    int ok = 1;
    b->K = K;
    b->x = data_of(bs, x, "x", b->N * b->M * b->n, 1, 0, 0, &ok);
    b->P = data_of(bs, P, "P", b->N * b->M * b->n * b->n, 1, 0, 0, &ok);
    b->mu = data_of(bs, mu, "mu", b->N * b->M, 1, 0, 1, &ok);
    b->rows = data_of(bs, rows, "rows", K, 0, 1, 1, &ok);
    return ok && check_rows(b);
}

static PyObject *py_predict(PyObject *self, PyObject *args) {
    Py_ssize_t N, K;
    int M, n, angle;
    PyObject *x, *P, *mu, *rows, *dt, *ground, *J, *F, *Q, *q_scale;
    if (!PyArg_ParseTuple(args, "niinOOOOOOOOOiO", &N, &M, &n, &K, &x, &P, &mu, &rows, &dt, &ground, &J, &F, &Q,
                          &angle, &q_scale))
        return NULL;
    if (!check_sizes(N, K, M, n, 0, angle)) return NULL;
    Buffers bs = {.count = 0};
    Bank b = {.N = N, .M = M, .n = n, .angle = angle};
    int ok = bank_of(&bs, &b, x, P, mu, rows, K);
    const double *dt_ = data_of(&bs, dt, "dt", K, 0, 0, 0, &ok);
    if (ok && !check_intervals(dt_, K)) ok = 0;
    b.ground = data_of(&bs, ground, "ground", M * GROUND_PARAMETERS, 0, 0, 1, &ok);
    b.J = data_of(&bs, J, "J", M * M, 0, 0, 1, &ok);
    b.q_scale = data_of(&bs, q_scale, "q_scale", K, 0, 0, 1, &ok);
    if (ok && !check_scales(b.q_scale, K)) ok = 0;
    const double *F_ = data_of(&bs, F, "F", K * M * n * n, 0, 0, 1, &ok);
    const double *Q_ = data_of(&bs, Q, "Q", K * M * n * n, 0, 0, 1, &ok);
    if (ok && (b.ground ? n != GROUND_DIM : !(F_ && Q_))) {
        PyErr_SetString(PyExc_ValueError, "predict needs ground models (n = 6) or F and Q");
        ok = 0;
    }
    if (ok && b.J && !b.mu) {
        PyErr_SetString(PyExc_ValueError, "mixing (J) needs mu");
        ok = 0;
    }
    if (ok) RUN(K, predict_rows(&b, dt_, F_, Q_));
    release(&bs);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyObject *py_innovate(PyObject *self, PyObject *args) {
    Py_ssize_t N, K;
    int M, n, m;
    PyObject *x, *P, *rows, *ground, *z, *R, *H, *y, *S, *Kg, *nis, *ll;
    if (!PyArg_ParseTuple(args, "niinnOOOOOOOOOOOO", &N, &M, &n, &K, &m, &x, &P, &rows, &ground, &z, &R, &H, &y,
                          &S, &Kg, &nis, &ll))
        return NULL;
    if (!check_sizes(N, K, M, n, m, -1)) return NULL;
    Buffers bs = {.count = 0};
    Bank b = {.N = N, .M = M, .n = n, .angle = -1};
    int ok = bank_of(&bs, &b, x, P, Py_None, rows, K);
    b.ground = data_of(&bs, ground, "ground", M * GROUND_PARAMETERS, 0, 0, 1, &ok);
    const double *z_ = data_of(&bs, z, "z", K * m, 0, 0, 0, &ok);
    const double *R_ = data_of(&bs, R, "R", K * m * m, 0, 0, 0, &ok);
    const double *H_ = data_of(&bs, H, "H", m * n, 0, 0, 1, &ok);
    double *y_ = data_of(&bs, y, "y", K * M * m, 1, 0, 0, &ok);
    double *S_ = data_of(&bs, S, "S", K * M * m * m, 1, 0, 0, &ok);
    double *K_ = data_of(&bs, Kg, "K", K * M * n * m, 1, 0, 0, &ok);
    double *nis_ = data_of(&bs, nis, "nis", K * M, 1, 0, 0, &ok);
    double *ll_ = data_of(&bs, ll, "log_likelihood", K * M, 1, 0, 0, &ok);
    if (ok && (b.ground ? n != GROUND_DIM || (m != 2 && m != 4) : !H_)) {
        PyErr_SetString(PyExc_ValueError, "innovate needs ground models (n = 6, m = 2 or 4) or H");
        ok = 0;
    }
    if (ok) RUN(K, innovate_rows(&b, m, z_, R_, H_, y_, S_, K_, nis_, ll_));
    release(&bs);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyObject *py_correct(PyObject *self, PyObject *args) {
    Py_ssize_t N, K;
    int M, n, m, angle;
    PyObject *x, *P, *mu, *rows, *ground, *y, *Kg, *R, *H, *ll;
    if (!PyArg_ParseTuple(args, "niinnOOOOOOOOOOi", &N, &M, &n, &K, &m, &x, &P, &mu, &rows, &ground, &y, &Kg, &R,
                          &H, &ll, &angle))
        return NULL;
    if (!check_sizes(N, K, M, n, m, angle)) return NULL;
    Buffers bs = {.count = 0};
    Bank b = {.N = N, .M = M, .n = n, .angle = angle};
    int ok = bank_of(&bs, &b, x, P, mu, rows, K);
    b.ground = data_of(&bs, ground, "ground", M * GROUND_PARAMETERS, 0, 0, 1, &ok);
    const double *y_ = data_of(&bs, y, "y", K * M * m, 0, 0, 0, &ok);
    const double *K_ = data_of(&bs, Kg, "K", K * M * n * m, 0, 0, 0, &ok);
    const double *R_ = data_of(&bs, R, "R", K * m * m, 0, 0, 0, &ok);
    const double *H_ = data_of(&bs, H, "H", m * n, 0, 0, 1, &ok);
    const double *ll_ = data_of(&bs, ll, "log_likelihood", K * M, 0, 0, 1, &ok);
    if (ok && (b.ground ? n != GROUND_DIM || (m != 2 && m != 4) : !H_)) {
        PyErr_SetString(PyExc_ValueError, "correct needs ground models (n = 6, m = 2 or 4) or H");
        ok = 0;
    }
    if (ok && b.mu && !ll_) {
        PyErr_SetString(PyExc_ValueError, "model probabilities (mu) need the log-likelihoods");
        ok = 0;
    }
    Py_ssize_t flipped = 0;
    if (ok) RUN(K, flipped = correct_rows(&b, m, y_, K_, R_, H_, ll_));
    release(&bs);
    if (!ok) return NULL;
    return PyLong_FromSsize_t(flipped);
}

static PyObject *py_forecast(PyObject *self, PyObject *args) {
    Py_ssize_t N, K;
    int M;
    PyObject *x, *P, *mu, *rows, *dt, *ground, *mean, *cov, *q_scale;
    if (!PyArg_ParseTuple(args, "ninOOOOOOOOO", &N, &M, &K, &x, &P, &mu, &rows, &dt, &ground, &mean, &cov,
                          &q_scale))
        return NULL;
    if (!check_sizes(N, K, M, GROUND_DIM, 0, -1)) return NULL;
    Buffers bs = {.count = 0};
    Bank b = {.N = N, .M = M, .n = GROUND_DIM, .angle = -1};
    int ok = bank_of(&bs, &b, x, P, mu, rows, K);
    const double *dt_ = data_of(&bs, dt, "dt", K, 0, 0, 0, &ok);
    if (ok && !check_intervals(dt_, K)) ok = 0;
    b.ground = data_of(&bs, ground, "ground", M * GROUND_PARAMETERS, 0, 0, 0, &ok);
    double *mean_ = data_of(&bs, mean, "mean", K * MMAX, 1, 0, 0, &ok);
    double *cov_ = data_of(&bs, cov, "cov", K * MMAX * MMAX, 1, 0, 0, &ok);
    b.q_scale = data_of(&bs, q_scale, "q_scale", K, 0, 0, 1, &ok);
    if (ok && !check_scales(b.q_scale, K)) ok = 0;
    if (ok && !b.mu) {
        PyErr_SetString(PyExc_ValueError, "forecast needs mu");
        ok = 0;
    }
    if (ok) RUN(K, forecast_rows(&b, dt_, mean_, cov_));
    release(&bs);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

/* ground_motion for L states: state i is model i % M over dt[i / M] */
static PyObject *py_ground_motion(PyObject *self, PyObject *args) {
    Py_ssize_t L;
    int M;
    PyObject *x, *dt, *ground, *xn, *F, *Q;
    if (!PyArg_ParseTuple(args, "niOOOOOO", &L, &M, &x, &dt, &ground, &xn, &F, &Q)) return NULL;
    if (!check_sizes(L, 0, M, GROUND_DIM, 0, -1) || L % M) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "states must be whole banks of M");
        return NULL;
    }
    Buffers bs = {.count = 0};
    int ok = 1, nn = GROUND_DIM * GROUND_DIM;
    const double *x_ = data_of(&bs, x, "x", L * GROUND_DIM, 0, 0, 0, &ok);
    const double *dt_ = data_of(&bs, dt, "dt", L / M, 0, 0, 0, &ok);
    const double *g_ = data_of(&bs, ground, "ground", M * GROUND_PARAMETERS, 0, 0, 0, &ok);
    double *xn_ = data_of(&bs, xn, "xn", L * GROUND_DIM, 1, 0, 0, &ok);
    double *F_ = data_of(&bs, F, "F", L * nn, 1, 0, 0, &ok);
    double *Q_ = data_of(&bs, Q, "Q", L * nn, 1, 0, 0, &ok);
    if (ok)
        for (Py_ssize_t i = 0; i < L; i++)
            ground_motion(x_ + i * GROUND_DIM, dt_[i / M], g_ + (i % M) * GROUND_PARAMETERS, xn_ + i * GROUND_DIM,
                          F_ + i * nn, Q_ + i * nn);
    release(&bs);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyObject *py_ground_measure(PyObject *self, PyObject *args) {
    Py_ssize_t L;
    int m;
    PyObject *x, *h, *H;
    if (!PyArg_ParseTuple(args, "niOOO", &L, &m, &x, &h, &H)) return NULL;
    if (m != 2 && m != 4) {
        PyErr_SetString(PyExc_ValueError, "a ground measurement has 2 or 4 components");
        return NULL;
    }
    if (!check_sizes(L, 0, 1, GROUND_DIM, m, -1)) return NULL;
    Buffers bs = {.count = 0};
    int ok = 1;
    const double *x_ = data_of(&bs, x, "x", L * GROUND_DIM, 0, 0, 0, &ok);
    double *h_ = data_of(&bs, h, "h", L * m, 1, 0, 0, &ok);
    double *H_ = data_of(&bs, H, "H", L * m * GROUND_DIM, 1, 0, 0, &ok);
    if (ok)
        for (Py_ssize_t i = 0; i < L; i++) ground_measure(m, x_ + i * GROUND_DIM, h_ + i * m, H_ + i * m * GROUND_DIM);
    release(&bs);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyObject *py_canonicalise(PyObject *self, PyObject *args) {
    Py_ssize_t L;
    PyObject *x, *P;
    if (!PyArg_ParseTuple(args, "nOO", &L, &x, &P)) return NULL;
    if (!check_sizes(L, 0, 1, GROUND_DIM, 0, -1)) return NULL;
    Buffers bs = {.count = 0};
    int ok = 1;
    double *x_ = data_of(&bs, x, "x", L * GROUND_DIM, 1, 0, 0, &ok);
    double *P_ = data_of(&bs, P, "P", L * GROUND_DIM * GROUND_DIM, 1, 0, 0, &ok);
    Py_ssize_t flipped = 0;
    if (ok)
        for (Py_ssize_t i = 0; i < L; i++)
            flipped += canonical(x_ + i * GROUND_DIM, P_ + i * GROUND_DIM * GROUND_DIM);
    release(&bs);
    if (!ok) return NULL;
    return PyLong_FromSsize_t(flipped);
}

static PyObject *py_mix(PyObject *self, PyObject *args) {
    Py_ssize_t K;
    int M, n, angle;
    PyObject *mu, *J, *x, *P, *cbar, *x0, *P0;
    if (!PyArg_ParseTuple(args, "niiOOOOiOOO", &K, &M, &n, &mu, &J, &x, &P, &angle, &cbar, &x0, &P0)) return NULL;
    if (!check_sizes(K, K, M, n, 0, angle)) return NULL;
    Buffers bs = {.count = 0};
    int ok = 1, nn = n * n;
    const double *mu_ = data_of(&bs, mu, "mu", K * M, 0, 0, 0, &ok);
    const double *J_ = data_of(&bs, J, "J", M * M, 0, 0, 0, &ok);
    const double *x_ = data_of(&bs, x, "x", K * M * n, 0, 0, 0, &ok);
    const double *P_ = data_of(&bs, P, "P", K * M * nn, 0, 0, 0, &ok);
    double *c_ = data_of(&bs, cbar, "cbar", K * M, 1, 0, 0, &ok);
    double *x0_ = data_of(&bs, x0, "x0", K * M * n, 1, 0, 0, &ok);
    double *P0_ = data_of(&bs, P0, "P0", K * M * nn, 1, 0, 0, &ok);
    if (ok)
        for (Py_ssize_t k = 0; k < K; k++)
            mix_track(M, n, mu_ + k * M, J_, x_ + k * M * n, P_ + k * M * nn, angle, c_ + k * M, x0_ + k * M * n,
                      P0_ + k * M * nn);
    release(&bs);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyObject *py_combine(PyObject *self, PyObject *args) {
    Py_ssize_t K;
    int M, n, angle;
    PyObject *mu, *x, *P, *xc, *Pc;
    if (!PyArg_ParseTuple(args, "niiOOOiOO", &K, &M, &n, &mu, &x, &P, &angle, &xc, &Pc)) return NULL;
    if (!check_sizes(K, K, M, n, 0, angle)) return NULL;
    Buffers bs = {.count = 0};
    int ok = 1, nn = n * n;
    const double *mu_ = data_of(&bs, mu, "mu", K * M, 0, 0, 0, &ok);
    const double *x_ = data_of(&bs, x, "x", K * M * n, 0, 0, 0, &ok);
    const double *P_ = data_of(&bs, P, "P", K * M * nn, 0, 0, 0, &ok);
    double *xc_ = data_of(&bs, xc, "xc", K * n, 1, 0, 0, &ok);
    double *Pc_ = data_of(&bs, Pc, "Pc", K * nn, 1, 0, 0, &ok);
    if (ok)
        for (Py_ssize_t k = 0; k < K; k++)
            combine_track(M, n, mu_ + k * M, x_ + k * M * n, P_ + k * M * nn, angle, xc_ + k * n, Pc_ + k * nn);
    release(&bs);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyObject *py_posterior(PyObject *self, PyObject *args) {
    Py_ssize_t K;
    int M;
    PyObject *prior, *ll, *mu;
    if (!PyArg_ParseTuple(args, "niOOO", &K, &M, &prior, &ll, &mu)) return NULL;
    if (!check_sizes(K, K, M, 1, 0, -1)) return NULL;
    Buffers bs = {.count = 0};
    int ok = 1;
    const double *p_ = data_of(&bs, prior, "prior", K * M, 0, 0, 0, &ok);
    const double *l_ = data_of(&bs, ll, "log_likelihood", K * M, 0, 0, 0, &ok);
    double *mu_ = data_of(&bs, mu, "mu", K * M, 1, 0, 0, &ok);
    if (ok)
        for (Py_ssize_t k = 0; k < K; k++) posterior_track(M, p_ + k * M, l_ + k * M, mu_ + k * M);
    release(&bs);
    if (!ok) return NULL;
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"predict", py_predict, METH_VARARGS, "Mix (with J) and predict the selected tracks in place."},
    {"innovate", py_innovate, METH_VARARGS, "Innovation, its covariance, gain, NIS, log-likelihood."},
    {"correct", py_correct, METH_VARARGS, "Joseph update, model probabilities, canonical speed."},
    {"forecast", py_forecast, METH_VARARGS, "Ground IMM predicted to [X, Y, Ẋ, Ẏ], moments combined."},
    {"ground_motion", py_ground_motion, METH_VARARGS, "f(x), ∇f and Q of ground models."},
    {"ground_measure", py_ground_measure, METH_VARARGS, "h(x) and ∇h of ground states."},
    {"canonicalise", py_canonicalise, METH_VARARGS, "Negative speeds made positive, in place."},
    {"mix", py_mix, METH_VARARGS, "IMM mixing (§5 step 1)."},
    {"combine", py_combine, METH_VARARGS, "IMM combination (§5 step 4)."},
    {"posterior", py_posterior, METH_VARARGS, "Model probabilities from priors and log-likelihoods."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_kalman", "Compiled Kalman and IMM kernels.", -1,
                                    methods};

PyMODINIT_FUNC PyInit__kalman(void) {
    PyObject *m = PyModule_Create(&module);
    if (!m) return NULL;
    /* the sizes the kernel takes, and where its turn terms switch to their series */
    if (PyModule_AddIntConstant(m, "MAX_STATES", NMAX) < 0 || PyModule_AddIntConstant(m, "MAX_MEASURED", MMAX) < 0 ||
        PyModule_AddIntConstant(m, "MAX_MODELS", KMAX) < 0 ||
        PyModule_AddObject(m, "SERIES_LIMIT", PyFloat_FromDouble(SERIES_LIMIT)) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
