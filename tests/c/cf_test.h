/*
 * cf_test.h -- a tiny always-on test harness for the C unit tests.
 *
 * Each tests/c/test_<concern>.c is one executable: it includes this header,
 * defines test functions, lists them in main() with CF_RUN(fn), and returns
 * CF_TEST_SUMMARY("name"), which prints "<name>: N passed, M failed" and gives
 * the exit status. A check failing prints file:line and the values; it never
 * aborts, so one run reports every failure.
 */
#ifndef CF_TEST_H
#define CF_TEST_H
#include <math.h>
#include <stdio.h>

static int cf_test_passed_ = 0, cf_test_failed_ = 0, cf_test_cur_failed_ = 0;

#define CF_CHECK(cond) do { if (!(cond)) { \
    fprintf(stderr, "  FAIL %s:%d: %s\n", __FILE__, __LINE__, #cond); cf_test_cur_failed_ = 1; } } while (0)

/* |a - b| <= tol (absolute) */
#define CF_CHECK_CLOSE(a, b, tol) do { double a_ = (a), b_ = (b), t_ = (tol); \
    if (!(fabs(a_ - b_) <= t_)) { fprintf(stderr, "  FAIL %s:%d: %s = %.17g, %s = %.17g, |diff| %.3g > %.3g\n", \
        __FILE__, __LINE__, #a, a_, #b, b_, fabs(a_ - b_), t_); cf_test_cur_failed_ = 1; } } while (0)

/* |a - b| <= rtol * |b| (relative to the expected value b) */
#define CF_CHECK_REL(a, b, rtol) do { double a_ = (a), b_ = (b), t_ = (rtol); \
    if (!(fabs(a_ - b_) <= t_ * fabs(b_))) { fprintf(stderr, "  FAIL %s:%d: %s = %.17g, %s = %.17g, rel %.3g > %.3g\n", \
        __FILE__, __LINE__, #a, a_, #b, b_, fabs(a_ - b_) / fabs(b_), t_); cf_test_cur_failed_ = 1; } } while (0)

#define CF_RUN(fn) do { cf_test_cur_failed_ = 0; fn(); \
    if (cf_test_cur_failed_) { cf_test_failed_++; fprintf(stderr, "FAILED %s\n", #fn); } else cf_test_passed_++; } while (0)

#define CF_TEST_SUMMARY(name) \
    (printf("%s: %d passed, %d failed\n", (name), cf_test_passed_, cf_test_failed_), cf_test_failed_ ? 1 : 0)

#endif
