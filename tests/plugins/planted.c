/* A library planted in a plugin folder beside the plugin an experiment uses: its constructor runs as soon as it is
 * mapped and writes the file GEOBARRIER_TEST_MARKER names. An experiment that does not use it must never map it
 * (test_cli: "only the libraries an experiment needs are loaded"). */
#include <geobarrier/abi.h>

#include <stdio.h>
#include <stdlib.h>

__attribute__((constructor)) static void geobarrier_planted_constructor(void) {
    const char *marker = getenv("GEOBARRIER_TEST_MARKER");
    if (!marker || !*marker) return;
    FILE *f = fopen(marker, "w");
    if (!f) return;
    fputs("the planted library's constructor ran\n", f);
    fclose(f);
}

GB_PLUGIN_EXPORT int geobarrier_planted(void) { return 1; }
