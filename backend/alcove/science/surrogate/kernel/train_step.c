/* Training kernel of the surrogate MLPs: forward, backpropagation and Adam in one call per epoch.
 *
 * Why C: a training step of the paper's nets (19-6-6-4-3 and 19-6-6-6-4-3, batch 1024) is
 * about 1.3 million multiply-adds and 40,000 exp/log pairs; in PyTorch it is ~60 tensor
 * operations whose dispatch and small-matrix BLAS overhead cost several times the arithmetic.
 * Here the batch is processed in chunks of CHUNK samples held feature-major (one row of
 * CHUNK doubles per unit), so every inner loop runs over samples with unit stride and is
 * vectorised (OpenMP SIMD; exp and log through glibc's vector math library, libmvec),
 * and a chunk's activations stay in the L1 cache through forward and backward.
 *
 * Semantics are those of alcove.science.surrogate.training's PyTorch path:
 *   - MLP: Linear layers (weight out x in, row-major, then bias, as torch.nn.Linear),
 *     activation on the hidden layers, identity output.
 *   - softplus(a) = log(1 + exp(a)), = a above SOFTPLUS_THRESHOLD (the nets' Softplus),
 *     slope exp(a) / (1 + exp(a)), = 1 above the threshold (torch's softplus_backward).
 *     tanh(a) = 1 - 2 / (exp(2a) + 1), sigmoid(a) = 1 / (1 + exp(-a)).
 *   - Loss of a batch of n samples: sum_i w_i mean_c (net(x_i) - y_i)_c^2 / n.
 *   - Adam as torch.optim.Adam (default, non-fused): m = lerp(m, g, 1 - b1),
 *     v = b2 v + (1 - b2) g^2, p -= lr / (1 - b1^t) * m / (sqrt(v) / sqrt(1 - b2^t) + eps).
 * Every reduction runs in a fixed order, so one build of this file gives bit-identical
 * results run after run; tests/science/surrogate compare it against autograd and torch.optim.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* math.h declares the libmvec variants only under -ffast-math, which would also allow
 * reassociation and assume no inf/NaN; declare them here instead (glibc >= 2.22). */
#ifdef ALCOVE_NO_LIBMVEC
#include <math.h>
#else
#pragma omp declare simd notinbranch
double exp(double);
#pragma omp declare simd notinbranch
double log(double);
double sqrt(double);
double pow(double, double);
#endif

#define CHUNK 128
#define SOFTPLUS_THRESHOLD 40.0
#define PREFETCH 8

enum { ACT_SOFTPLUS = 0, ACT_TANH = 1, ACT_SIGMOID = 2 };

typedef struct {
    int32_t n_layers;       /* Linear layers */
    int32_t activation;     /* ACT_* on the hidden layers */
    int32_t y_col;          /* first target column in the table */
    int32_t active;         /* 0: the net has stopped training, skip it */
    const int32_t *widths;  /* n_layers + 1: inputs, hidden widths, outputs */
    double *params;         /* per layer: weight (out x in), bias (out) */
    double *grad;           /* same layout */
    double *exp_avg;        /* Adam moments, same layout */
    double *exp_avg_sq;
    int64_t steps;          /* Adam steps taken */
} Net;

static int64_t n_params(const Net *net) {
    int64_t n = 0;
    for (int l = 0; l < net->n_layers; l++) n += (int64_t)net->widths[l + 1] * (net->widths[l] + 1);
    return n;
}

static int64_t n_units(const Net *net) { /* hidden units + outputs */
    int64_t n = 0;
    for (int l = 1; l <= net->n_layers; l++) n += net->widths[l];
    return n;
}

/* h = activation(a) in place, s = its slope; cn samples. */
static void activate(int act, double *restrict h, double *restrict s, int cn) {
    if (act == ACT_SOFTPLUS) {
#pragma omp simd
        for (int b = 0; b < cn; b++) {
            double a = h[b];
            double e = exp(a < SOFTPLUS_THRESHOLD ? a : SOFTPLUS_THRESHOLD);
            double d = 1.0 + e;
            h[b] = a > SOFTPLUS_THRESHOLD ? a : log(d);
            s[b] = a > SOFTPLUS_THRESHOLD ? 1.0 : e / d;
        }
    } else if (act == ACT_TANH) {
#pragma omp simd
        for (int b = 0; b < cn; b++) {
            double t = 1.0 - 2.0 / (exp(2.0 * h[b]) + 1.0);
            h[b] = t;
            s[b] = 1.0 - t * t;
        }
    } else {
#pragma omp simd
        for (int b = 0; b < cn; b++) {
            double g = 1.0 / (1.0 + exp(-h[b]));
            h[b] = g;
            s[b] = g - g * g;
        }
    }
}

/* One layer: out[o][b] = bias[o] + sum_i W[o][i] in[i][b] (rows of CHUNK doubles). */
static void linear(const double *restrict W, const double *restrict bias, int I, int O,
                   const double *restrict in, double *restrict out, int cn) {
    for (int o = 0; o < O; o++) {
        double *restrict a = out + (int64_t)o * CHUNK;
        const double bo = bias[o];
#pragma omp simd
        for (int b = 0; b < cn; b++) a[b] = bo;
        for (int i = 0; i < I; i++) {
            const double w = W[(int64_t)o * I + i];
            const double *restrict x = in + (int64_t)i * CHUNK;
#pragma omp simd
            for (int b = 0; b < cn; b++) a[b] += w * x[b];
        }
    }
}

/* Forward of one net on a chunk: units (hidden layers then output, CHUNK doubles per unit),
 * slopes of the hidden units. */
static void forward_chunk(const Net *net, const double *x, double *units, double *slopes, int cn) {
    const double *in = x, *p = net->params;
    double *u = units, *s = slopes;
    for (int l = 0; l < net->n_layers; l++) {
        int I = net->widths[l], O = net->widths[l + 1];
        linear(p, p + (int64_t)O * I, I, O, in, u, cn);
        if (l < net->n_layers - 1)
            for (int o = 0; o < O; o++) activate(net->activation, u + (int64_t)o * CHUNK, s + (int64_t)o * CHUNK, cn);
        p += (int64_t)O * (I + 1);
        in = u;
        u += (int64_t)O * CHUNK;
        s += (int64_t)O * CHUNK;
    }
}

/* Gradient of the chunk's share of the batch loss, added to net->grad. Each layer's units are
 * overwritten by dLoss/d(unit) on the way back. */
static void backward_chunk(const Net *net, const double *x, double *units, const double *slopes, const double *y,
                           const double *w, double scale, int cn) {
    int L = net->n_layers;
    int64_t offs_u[L + 1], offs_p[L + 1];
    offs_u[0] = 0;
    offs_p[0] = 0;
    for (int l = 0; l < L; l++) {
        offs_u[l + 1] = offs_u[l] + (int64_t)net->widths[l + 1] * CHUNK;
        offs_p[l + 1] = offs_p[l] + (int64_t)net->widths[l + 1] * (net->widths[l] + 1);
    }
    int n_out = net->widths[L];
    double *g = units + offs_u[L - 1]; /* the output layer: residuals in place */
    const double c = scale / n_out;
    for (int o = 0; o < n_out; o++) {
        double *restrict r = g + (int64_t)o * CHUNK;
        const double *restrict t = y + (int64_t)o * CHUNK;
#pragma omp simd
        for (int b = 0; b < cn; b++) r[b] = (r[b] - t[b]) * (c * w[b]);
    }
    for (int l = L - 1; l >= 0; l--) {
        int I = net->widths[l], O = net->widths[l + 1];
        const double *in = l == 0 ? x : units + offs_u[l - 1];
        const double *W = net->params + offs_p[l];
        double *dW = net->grad + offs_p[l], *db = dW + (int64_t)O * I;
        for (int o = 0; o < O; o++) {
            const double *restrict go = g + (int64_t)o * CHUNK;
            double sb = 0.0;
#pragma omp simd reduction(+ : sb)
            for (int b = 0; b < cn; b++) sb += go[b];
            db[o] += sb;
            for (int i = 0; i < I; i++) {
                const double *restrict xi = in + (int64_t)i * CHUNK;
                double sw = 0.0;
#pragma omp simd reduction(+ : sw)
                for (int b = 0; b < cn; b++) sw += go[b] * xi[b];
                dW[(int64_t)o * I + i] += sw;
            }
        }
        if (l == 0) break;
        /* dLoss/d(hidden units of layer l - 1) = slope * W^T g, written over those units
         * (their values are not needed any more: dW of layer l has been accumulated). */
        const double *sl = slopes + offs_u[l - 1];
        double *gp = units + offs_u[l - 1];
        for (int i = 0; i < I; i++) {
            double *restrict d = gp + (int64_t)i * CHUNK;
            const double *restrict s = sl + (int64_t)i * CHUNK;
#pragma omp simd
            for (int b = 0; b < cn; b++) d[b] = 0.0;
            for (int o = 0; o < O; o++) {
                const double wo = W[(int64_t)o * I + i];
                const double *restrict go = g + (int64_t)o * CHUNK;
#pragma omp simd
                for (int b = 0; b < cn; b++) d[b] += wo * go[b];
            }
#pragma omp simd
            for (int b = 0; b < cn; b++) d[b] *= s[b];
        }
        g = gp;
    }
}

static int max_width(int n_nets, const Net *nets) {
    int m = 1;
    for (int k = 0; k < n_nets; k++)
        for (int l = 0; l <= nets[k].n_layers; l++)
            if (nets[k].widths[l] > m) m = nets[k].widths[l];
    return m;
}

static int64_t max_units(int n_nets, const Net *nets) {
    int64_t m = 1;
    for (int k = 0; k < n_nets; k++)
        if (n_units(&nets[k]) > m) m = n_units(&nets[k]);
    return m;
}

/* Gather rows[0..cn) of the row-major table into feature-major chunk buffers. */
static void gather(const double *table, int64_t ld, const int64_t *rows, int cn, int n_in, int w_col, double *x,
                   double *w) {
    for (int b = 0; b < cn; b++) {
        if (b + PREFETCH < cn) { /* rows come in random order: fetch ahead, several cache misses in flight */
            const char *ahead = (const char *)(table + rows[b + PREFETCH] * ld);
            for (int64_t byte = 0; byte < ld * (int64_t)sizeof(double); byte += 64) __builtin_prefetch(ahead + byte);
        }
        const double *row = table + rows[b] * ld;
        for (int i = 0; i < n_in; i++) x[(int64_t)i * CHUNK + b] = row[i];
        w[b] = row[w_col];
    }
}

static void gather_targets(const double *table, int64_t ld, const int64_t *rows, int cn, int col, int n_out,
                           double *y) {
    for (int b = 0; b < cn; b++) {
        const double *row = table + rows[b] * ld + col;
        for (int c = 0; c < n_out; c++) y[(int64_t)c * CHUNK + b] = row[c];
    }
}

/* Scratch of a gradient call: a chunk's inputs, weights, units, slopes and targets. */
static double *scratch(int32_t n_nets, const Net *nets, int32_t n_in) {
    return malloc(sizeof(double) * CHUNK * ((int64_t)n_in + 1 + 2 * max_units(n_nets, nets) + max_width(n_nets, nets)));
}

/* Set every active net's grad to the gradient of its loss on the n samples rows[0..n). */
static void gradient(int32_t n_nets, Net *nets, const double *table, int64_t ld, int32_t n_in, int32_t w_col,
                     const int64_t *rows, int64_t n, double *buf) {
    int64_t mu = max_units(n_nets, nets);
    double *x = buf, *w = x + (int64_t)n_in * CHUNK, *units = w + CHUNK, *slopes = units + mu * CHUNK,
           *y = slopes + mu * CHUNK;
    for (int k = 0; k < n_nets; k++)
        if (nets[k].active) memset(nets[k].grad, 0, sizeof(double) * n_params(&nets[k]));
    const double scale = 2.0 / (double)n;
    for (int64_t start = 0; start < n; start += CHUNK) {
        int cn = (int)(n - start < CHUNK ? n - start : CHUNK);
        gather(table, ld, rows + start, cn, n_in, w_col, x, w);
        for (int k = 0; k < n_nets; k++) {
            const Net *net = &nets[k];
            if (!net->active) continue;
            int n_out = net->widths[net->n_layers];
            gather_targets(table, ld, rows + start, cn, net->y_col, n_out, y);
            forward_chunk(net, x, units, slopes, cn);
            backward_chunk(net, x, units, slopes, y, w, scale, cn);
        }
    }
}

int alcove_gradient(int32_t n_nets, Net *nets, const double *table, int64_t ld, int32_t n_in, int32_t w_col,
                    const int64_t *rows, int64_t n) {
    double *buf = scratch(n_nets, nets, n_in);
    if (!buf) return 1;
    gradient(n_nets, nets, table, ld, n_in, w_col, rows, n, buf);
    free(buf);
    return 0;
}

static void adam(Net *net, double lr, double beta1, double beta2, double eps) {
    net->steps += 1;
    const double bias1 = 1.0 - pow(beta1, (double)net->steps), bias2 = 1.0 - pow(beta2, (double)net->steps);
    const double step_size = lr / bias1, bias2_sqrt = sqrt(bias2);
    const int64_t n = n_params(net);
    double *restrict p = net->params, *restrict m = net->exp_avg, *restrict v = net->exp_avg_sq;
    const double *restrict g = net->grad;
    for (int64_t j = 0; j < n; j++) {
        m[j] += (1.0 - beta1) * (g[j] - m[j]);
        v[j] = v[j] * beta2 + (1.0 - beta2) * g[j] * g[j];
        p[j] += -step_size * (m[j] / (sqrt(v[j]) / bias2_sqrt + eps));
    }
}

/* One epoch: batches of `batch` consecutive entries of perm (rows of the table), an Adam
 * step of every active net after each. Returns 0, or 1 when out of memory. */
int alcove_train_epoch(int32_t n_nets, Net *nets, const double *table, int64_t ld, int32_t n_in, int32_t w_col,
                       const int64_t *perm, int64_t n, int64_t batch, double lr, double beta1, double beta2,
                       double eps) {
    double *buf = scratch(n_nets, nets, n_in);
    if (!buf) return 1;
    for (int64_t start = 0; start < n; start += batch) {
        int64_t bn = n - start < batch ? n - start : batch;
        gradient(n_nets, nets, table, ld, n_in, w_col, perm + start, bn, buf);
        for (int k = 0; k < n_nets; k++)
            if (nets[k].active) adam(&nets[k], lr, beta1, beta2, eps);
    }
    free(buf);
    return 0;
}

/* Outputs (n x n_out, row-major) of one net for the n rows of x (row-major, leading dimension ldx). */
int alcove_forward(const Net *net, const double *x, int64_t ldx, int64_t n, double *out) {
    int n_in = net->widths[0], n_out = net->widths[net->n_layers];
    int64_t mu = n_units(net);
    double *buf = malloc(sizeof(double) * CHUNK * ((int64_t)n_in + 2 * mu));
    if (!buf) return 1;
    double *xc = buf, *units = xc + (int64_t)n_in * CHUNK, *slopes = units + mu * CHUNK;
    double *outputs = units + (mu - n_out) * CHUNK;
    for (int64_t start = 0; start < n; start += CHUNK) {
        int cn = (int)(n - start < CHUNK ? n - start : CHUNK);
        for (int b = 0; b < cn; b++)
            for (int i = 0; i < n_in; i++) xc[(int64_t)i * CHUNK + b] = x[(start + b) * ldx + i];
        forward_chunk(net, xc, units, slopes, cn);
        for (int b = 0; b < cn; b++)
            for (int c = 0; c < n_out; c++) out[(start + b) * n_out + c] = outputs[(int64_t)c * CHUNK + b];
    }
    free(buf);
    return 0;
}
