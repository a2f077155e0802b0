/* Linked beside the unmodified stream.c by run.sh: asks for transparent huge pages for STREAM's arrays, as gbuf's
 * allocator does for its large blocks (src/base/alloc.rs), and reports at exit how much of them huge pages backed.
 *
 * stream.c's arrays a, b, c are static, zero-initialised: they lie in the BSS, between the linker's __bss_start and
 * _end (with -mcmodel=medium they move to .lbss, which the default x86-64 linker script also places before _end). A
 * constructor runs before main, so before STREAM first touches them: madvise(MADV_HUGEPAGE) on the page-aligned
 * part of that range then lets the page faults of STREAM's first loop take 2 MiB pages where the system's
 * transparent huge pages are "madvise" (or "always"). Built with -DTHP_ADVISE=0 it only reports (the 4 KiB variant).
 *
 * Report, one line on stderr at exit:
 *   thp.c: advise=1 madvise=0 bss_kib=1593756 anon_huge_kib=1591296
 * advise: whether it asked; madvise: the call's return (0 ok, -1 refused: errno follows; "-" when not asked);
 * bss_kib: the advised range; anon_huge_kib: AnonHugePages of the mappings that overlap it, from /proc/self/smaps.
 * No memcpy/memset calls here: run.sh's store check disassembles the whole binary. */
#define _GNU_SOURCE
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#ifndef THP_ADVISE
#define THP_ADVISE 1
#endif

extern char __bss_start, _end;

static uintptr_t lo, hi;
static int advised_rc = 0, advised_errno = 0;

__attribute__((constructor)) static void thp_advise(void) {
    uintptr_t pg = (uintptr_t)sysconf(_SC_PAGESIZE);
    lo = ((uintptr_t)&__bss_start + pg - 1) & ~(pg - 1);
    hi = (uintptr_t)&_end & ~(pg - 1);
    if (hi <= lo) { lo = hi = 0; return; }
#if THP_ADVISE
    advised_rc = madvise((void *)lo, hi - lo, MADV_HUGEPAGE);
    advised_errno = advised_rc ? errno : 0;
#endif
}

__attribute__((destructor)) static void thp_report(void) {
    unsigned long long huge_kib = 0;
    int overlap = 0;
    char line[512];
    FILE *f = fopen("/proc/self/smaps", "r");
    if (f) {
        while (fgets(line, sizeof line, f)) {
            unsigned long long s, e, v;
            if (sscanf(line, "%llx-%llx ", &s, &e) == 2 && strchr(line, '-') < strchr(line, ' '))
                overlap = s < hi && e > lo;
            else if (overlap && sscanf(line, "AnonHugePages: %llu kB", &v) == 1)
                huge_kib += v;
        }
        fclose(f);
    }
    if (THP_ADVISE)
        fprintf(stderr, "thp.c: advise=1 madvise=%d%s%s bss_kib=%llu anon_huge_kib=%llu\n", advised_rc,
                advised_rc ? " errno=" : "", advised_rc ? strerror(advised_errno) : "",
                (unsigned long long)((hi - lo) >> 10), f ? huge_kib : 0ULL);
    else
        fprintf(stderr, "thp.c: advise=0 madvise=- bss_kib=%llu anon_huge_kib=%llu\n",
                (unsigned long long)((hi - lo) >> 10), f ? huge_kib : 0ULL);
}
