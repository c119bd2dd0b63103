/* Cascaded biquads (transposed direct form II, the order of scipy.signal.sosfilt) over k signals
   stored time-major: x[t*k + j]. z: (ns, 2, k) state, updated. y may be x. */
void sosfilt_tm(const double *sos, int ns, const double *x, double *y, long n, long k,
                double *z, int reverse)
{
    for (long i = 0; i < n; ++i) {
        long t = reverse ? n - 1 - i : i;
        const double *xt = x + t * k;
        double *yt = y + t * k;
        for (int s = 0; s < ns; ++s) {
            const double b0 = sos[6 * s], b1 = sos[6 * s + 1], b2 = sos[6 * s + 2];
            const double a1 = sos[6 * s + 4], a2 = sos[6 * s + 5];
            double *restrict z0 = z + (2 * s) * k;
            double *restrict z1 = z + (2 * s + 1) * k;
            const double *in = s == 0 ? xt : yt;
            for (long j = 0; j < k; ++j) {
                double xi = in[j];
                double yi = b0 * xi + z0[j];
                z0[j] = b1 * xi - a1 * yi + z1[j];
                z1[j] = b2 * xi - a2 * yi;
                yt[j] = yi;
            }
        }
    }
}
