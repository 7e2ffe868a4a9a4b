/* Closed-form view factors (Howell's catalogue; Incropera, Table 13.2) and the area average
 * of an operator's F̄ between two groups of triangles: shared by the rasteriser's and the ray
 * caster's tests. Include after testutil.h and operator/operator.h. */
#ifndef LRR_TESTS_CLOSED_FORMS_H
#define LRR_TESTS_CLOSED_FORMS_H

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static inline double parallel_closed_form(double X, double Y)
{
    double a = log(sqrt((1 + X * X) * (1 + Y * Y) / (1 + X * X + Y * Y)));
    double b = X * sqrt(1 + Y * Y) * atan(X / sqrt(1 + Y * Y));
    double c = Y * sqrt(1 + X * X) * atan(Y / sqrt(1 + X * X));
    return 2 / (M_PI * X * Y) * (a + b + c - X * atan(X) - Y * atan(Y));
}

static inline double perpendicular_closed_form(double W, double H)
{
    double s = sqrt(H * H + W * W);
    double l1 = (1 + W * W) * (1 + H * H) / (1 + W * W + H * H);
    double l2 = pow(W * W * (1 + W * W + H * H) / ((1 + W * W) * (W * W + H * H)), W * W);
    double l3 = pow(H * H * (1 + W * W + H * H) / ((1 + H * H) * (W * W + H * H)), H * H);
    return 1 / (M_PI * W) *
           (W * atan(1 / W) + H * atan(1 / H) - s * atan(1 / s) + 0.25 * log(l1 * l2 * l3));
}

/* Area-averaged F from the first `tri1` triangles to the rest, from F̄·d. */
static inline double area_average(const lrr_operator *op, size_t tri1)
{
    size_t k1 = op->geom.patch0[tri1];
    double num = 0, den = 0;
    for (size_t i = 0; i < k1 * op->d; i++) {
        double row = 0;
        for (size_t p = k1; p < op->k; p++)
            row += op->fbar[i * op->k + p];
        num += op->area[i] * row * (double)op->d;
        den += op->area[i];
    }
    return num / den;
}

#endif
