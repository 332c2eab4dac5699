/* Status names and version of cf_common. */
#include <string.h>
#include "cf_test.h"
#include "cf_common.h"

static void test_status_names(void)
{
    CF_CHECK(strcmp(cf_common_status_name(CF_OK), "CF_OK") == 0);
    CF_CHECK(strcmp(cf_common_status_name(CF_EINVAL), "CF_EINVAL") == 0);
    CF_CHECK(strcmp(cf_common_status_name(12345), "CF_UNKNOWN") == 0);
}

static void test_version(void)
{
    /* must equal pycolfrag.__version__ (checked again at import) */
    CF_CHECK(strcmp(cf_common_version(), "0.1.0") == 0);
}

int main(void)
{
    CF_RUN(test_status_names);
    CF_RUN(test_version);
    return CF_TEST_SUMMARY("test_common");
}
