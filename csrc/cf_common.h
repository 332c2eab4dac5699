/*
 * cf_common.h -- status codes and version shared by every part of libcolfrag.
 *
 * Conventions for the whole library:
 *  - every exported symbol is prefixed cf_<concern>_ (this file: cf_common_);
 *  - every fallible function returns a cf_status (CF_OK == 0) and, where it
 *    works on an object, leaves a human-readable message on that object;
 *  - nothing prints, exits or aborts, and there is no global mutable state.
 * The region between the cffi markers is read verbatim by pycolfrag/_build.py.
 */
#ifndef CF_COMMON_H
#define CF_COMMON_H

#define CF_PI 3.14159265358979323846

/* cffi:begin */
#define CF_MSG_LEN 256

typedef enum {
    CF_OK = 0,          /* success */
    CF_EINVAL = 1,      /* invalid argument (bad value, size, geometry) */
    CF_ENOMEM = 2,      /* allocation failed */
    CF_EUNSTABLE = 3,   /* numerical instability detected (NaN, energy blow-up) */
    CF_ERANGE = 4,      /* argument outside the model's calibrated range */
    CF_ESTATE = 5,      /* object used in the wrong state */
    CF_EINTR = 6        /* stopped by the caller's check (e.g. an interrupt from the user) */
} cf_status;

/* Name of a status code ("CF_EINVAL", ...); never NULL. */
const char *cf_common_status_name(int status);

/* Library version string, e.g. "0.1.0"; Python checks it at import. */
const char *cf_common_version(void);

/* SHA-256 (64 hex digits) of the sources this library was compiled from (csrc/ *.c, *.h, flags.mk,
 * pycolfrag/_build.py, pycolfrag/data/constants.json: pycolfrag/core/source_digest.py), computed by
 * the extension's build (the macro CF_SOURCE_DIGEST); "none" for a build without it (the C tests).
 * Results are signed by it: it names the binary that runs, not the sources on disk. */
const char *cf_common_source_digest(void);

/* Returns a*b + c as this library's compiler flags evaluate it. With
 * floating-point contraction off (-ffp-contract=off) this is the product rounded,
 * then the sum rounded; a fused multiply-add would round once. Used by a test to
 * prove that the build is reproducible across CPUs (REBOUND's fpcontract test). */
double cf_common_fma_probe(double a, double b, double c);
/* cffi:end */

/* The library's one way of failing with a message: formats it (printf-style, cut at CF_MSG_LEN)
 * into msg, the message buffer of the object that failed, and returns status. At the bottom of
 * the layering, so any file can report a failure without calling up into the file that owns
 * the object's public API. Not in the cffi region: Python reads the messages, not this. */
int cf_common_fail(char *msg, int status, const char *fmt, ...)
#ifdef __GNUC__
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#endif
