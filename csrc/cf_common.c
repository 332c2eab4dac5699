/* cf_common.c -- status names, library version, and the message of a failure. */
#include <stdarg.h>
#include <stdio.h>

#include "cf_common.h"

#define CF_VERSION "0.1.0"

/* pycolfrag/_build.py defines it as the digest of the build's inputs; other builds have none */
#ifndef CF_SOURCE_DIGEST
#define CF_SOURCE_DIGEST "none"
#endif

const char *cf_common_status_name(int status)
{
    switch (status) {
    case CF_OK: return "CF_OK";
    case CF_EINVAL: return "CF_EINVAL";
    case CF_ENOMEM: return "CF_ENOMEM";
    case CF_EUNSTABLE: return "CF_EUNSTABLE";
    case CF_ERANGE: return "CF_ERANGE";
    case CF_ESTATE: return "CF_ESTATE";
    case CF_EINTR: return "CF_EINTR";
    default: return "CF_UNKNOWN";
    }
}

const char *cf_common_version(void) { return CF_VERSION; }

const char *cf_common_source_digest(void) { return CF_SOURCE_DIGEST; }

double cf_common_fma_probe(double a, double b, double c) { return a * b + c; }

int cf_common_fail(char *msg, int status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, CF_MSG_LEN, fmt, ap);
    va_end(ap);
    return status;
}
