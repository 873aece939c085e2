/* One core's double-precision FMA throughput: 12 independent chains x = x * m + a in
   registers (scalar, 4-wide and 8-wide vectors); process CPU time, best of 5. The vector
   runs need registers that wide (AVX, AVX-512): without them they are left out. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
typedef double v4 __attribute__((vector_size(32)));
typedef double v8 __attribute__((vector_size(64)));
static double cpu(void) {
  struct timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}
#define STEP(x) x = x * m + a;
#define RUN(T, W, NAME)                                                              \
  {                                                                                  \
    T m = (T){0} + 0.999999, a = (T){0} + 1e-7;                                      \
    T x0 = (T){0} + 1.0, x1 = x0 + 1e-3, x2 = x0 + 2e-3, x3 = x0 + 3e-3;             \
    T x4 = x0 + 4e-3, x5 = x0 + 5e-3, x6 = x0 + 6e-3, x7 = x0 + 7e-3;                \
    T x8 = x0 + 8e-3, x9 = x0 + 9e-3, xa = x0 + 1e-2, xb = x0 + 1.1e-2;              \
    double best = 0;                                                                 \
    for (int rep = 0; rep < 5; rep++) {                                              \
      double t0 = cpu();                                                             \
      for (long i = 0; i < n; i++) {                                                 \
        STEP(x0) STEP(x1) STEP(x2) STEP(x3) STEP(x4) STEP(x5)                        \
        STEP(x6) STEP(x7) STEP(x8) STEP(x9) STEP(xa) STEP(xb)                        \
        __asm__ volatile("" : "+x"(x0), "+x"(x1), "+x"(x2), "+x"(x3), "+x"(x4),     \
                         "+x"(x5), "+x"(x6), "+x"(x7), "+x"(x8), "+x"(x9), "+x"(xa), \
                         "+x"(xb));                                                   \
      }                                                                              \
      double g = 2.0 * W * 12 * n / (cpu() - t0) / 1e9;                              \
      if (g > best) best = g;                                                        \
    }                                                                                \
    T s = x0 + x1 + x2 + x3 + x4 + x5 + x6 + x7 + x8 + x9 + xa + xb;                 \
    printf("%s %.3f %.6g\n", NAME, best, ((double *)&s)[0]);                         \
  }
int main(int argc, char **argv) {
  long n = argc > 1 ? atol(argv[1]) : 20000000;
  RUN(double, 1, "scalar")
#ifdef __AVX__
  RUN(v4, 4, "vec4")
#endif
#ifdef __AVX512F__
  RUN(v8, 8, "vec8")
#endif
  return 0;
}
