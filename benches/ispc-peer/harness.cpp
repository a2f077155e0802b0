// Timing harness for the serial C++ path of ISPC's examples/cpu/deferred (DispatchDynamicC), for the side-by-side
// peer measurement against gbuf (gbuf issue 14, target 2). Kept in gbuf's benches/ispc-peer/ (not built by Cargo);
// build.sh compiles it with the example's own common.cpp (file reader, WriteFrame) and dynamic_c.cpp, unchanged,
// which it extracts from an ispc/ispc snapshot into the work dir (they are not in gbuf's repository).
//
//   harness bench FILE.bin [N] [OUT.ppm]  N timed runs (default 7) of
//       (a) DispatchDynamicC alone on input loaded once (as main.cpp times it), and
//       (b) the like-for-like frame: file bytes -> arrays (CreateInputDataFromFile: fread of header + chunk; the
//           example has no other input conversion: it decodes the f16/unorm8 arrays inside the shading loop)
//           -> InitDynamicC -> DispatchDynamicC (lit, gamma-encoded 8-bit planar framebuffer) -> WriteFrame
//           (deswizzle to interleaved RGB8 + PPM write; the example's only output conversion).
//       Per run: thread CPU time (CLOCK_THREAD_CPUTIME_ID) and wall (CLOCK_MONOTONIC); prints min / median.
//   harness frame FILE.bin OUT.ppm        one like-for-like frame, then exit (for /usr/bin/time, process level).
//   harness count FILE.bin                light-pixel pairs the C++ shades (only in the counting build, see build.sh).
//
// Output lines are "key value" pairs, easy to grep from run.sh.
#include "deferred.h"

#include <algorithm>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <string>
#include <time.h>
#include <vector>

#ifdef PEER_COUNT
extern long long g_peer_pairs;   // defined in the counting copy of dynamic_c.cpp (build.sh)
extern long long g_peer_pixels;
#endif

static double now_ms(clockid_t c) {
    timespec t;
    clock_gettime(c, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

struct Timer {
    double cpu0, wall0;
    Timer() : cpu0(now_ms(CLOCK_THREAD_CPUTIME_ID)), wall0(now_ms(CLOCK_MONOTONIC)) {}
    double cpu() const { return now_ms(CLOCK_THREAD_CPUTIME_ID) - cpu0; }
    double wall() const { return now_ms(CLOCK_MONOTONIC) - wall0; }
};

static double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
static double minimum(const std::vector<double> &v) { return *std::min_element(v.begin(), v.end()); }

static unsigned long long checksum(const Framebuffer &fb, int n) {
    unsigned long long h = 1469598103934665603ull;
    for (int i = 0; i < n; ++i) {
        h = (h ^ fb.r[i]) * 1099511628211ull;
        h = (h ^ fb.g[i]) * 1099511628211ull;
        h = (h ^ fb.b[i]) * 1099511628211ull;
    }
    return h;
}

static void report(const char *key, const std::vector<double> &v) {
    printf("%s_min_ms %.3f\n%s_median_ms %.3f\n", key, minimum(v), key, median(v));
}

// Stage times of one like-for-like frame (thread CPU ms; wall for the whole).
struct FrameTimes {
    double read, init, dispatch, write, total_cpu, total_wall;
};

static FrameTimes one_frame(const char *path, const char *out, unsigned long long *sum) {
    FrameTimes t;
    Timer all;
    Timer s;
    InputData *input = CreateInputDataFromFile(path);
    if (!input) {
        fprintf(stderr, "cannot read %s\n", path);
        exit(1);
    }
    t.read = s.cpu();
    s = Timer();
    InitDynamicC(input); // (the example's tree of the previous frame leaks: a few KB, global in dynamic_c.cpp)
    Framebuffer fb(input->header.framebufferWidth, input->header.framebufferHeight);
    t.init = s.cpu();
    s = Timer();
    DispatchDynamicC(input, &fb);
    t.dispatch = s.cpu();
    s = Timer();
    WriteFrame(out, input, fb);
    t.write = s.cpu();
    t.total_cpu = all.cpu();
    t.total_wall = all.wall();
    if (sum)
        *sum = checksum(fb, input->header.framebufferWidth * input->header.framebufferHeight);
    DeleteInputData(input);
    delete input;
    return t;
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s bench FILE.bin [N] [OUT.ppm] | frame FILE.bin OUT.ppm | count FILE.bin\n", argv[0]);
        return 2;
    }
    std::string mode = argv[1];
    const char *path = argv[2];

    if (mode == "frame") {
        if (argc < 4) {
            fprintf(stderr, "frame needs OUT.ppm\n");
            return 2;
        }
        unsigned long long sum = 0;
        FrameTimes t = one_frame(path, argv[3], &sum);
        printf("frame_read_ms %.3f\nframe_init_ms %.3f\nframe_dispatch_ms %.3f\nframe_write_ms %.3f\n"
               "frame_cpu_ms %.3f\nframe_wall_ms %.3f\nchecksum %016llx\n",
               t.read, t.init, t.dispatch, t.write, t.total_cpu, t.total_wall, sum);
        return 0;
    }

    InputData *input = CreateInputDataFromFile(path);
    if (!input) {
        fprintf(stderr, "cannot read %s\n", path);
        return 1;
    }
    const int w = input->header.framebufferWidth, h = input->header.framebufferHeight;
    printf("file %s\nwidth %d\nheight %d\nnum_lights %d\n", path, w, h, input->header.numLights);
    Framebuffer fb(w, h);
    InitDynamicC(input);

    if (mode == "count") {
#ifdef PEER_COUNT
        fb.clear();
        DispatchDynamicC(input, &fb);
        printf("pairs %lld\npixels %lld\nlights_per_pixel %.3f\n", g_peer_pairs, g_peer_pixels,
               (double)g_peer_pairs / (double)(w * (long long)h));
        return 0;
#else
        fprintf(stderr, "count needs the counting build (harness-count)\n");
        return 2;
#endif
    }
    if (mode != "bench") {
        fprintf(stderr, "unknown mode %s\n", mode.c_str());
        return 2;
    }
    int n = argc > 3 ? atoi(argv[3]) : 7;
    const char *out = argc > 4 ? argv[4] : "/dev/null";

    // (a) DispatchDynamicC alone, input loaded once (main.cpp's "serial" timing, in thread CPU time per frame).
    fb.clear();
    DispatchDynamicC(input, &fb); // warm-up
    std::vector<double> cpu, wall;
    for (int i = 0; i < n; ++i) {
        fb.clear();
        Timer t;
        DispatchDynamicC(input, &fb);
        cpu.push_back(t.cpu());
        wall.push_back(t.wall());
    }
    printf("checksum %016llx\n", checksum(fb, w * h));
    report("dispatch_cpu", cpu);
    report("dispatch_wall", wall);
    WriteFrame(out, input, fb);
    DeleteInputData(input);
    delete input;

    // (b) the like-for-like frame, from the file each time (warm page cache, as for gbuf).
    std::vector<double> rd, in, di, wr, tc, tw;
    one_frame(path, out, nullptr); // warm-up
    for (int i = 0; i < n; ++i) {
        FrameTimes t = one_frame(path, out, nullptr);
        rd.push_back(t.read);
        in.push_back(t.init);
        di.push_back(t.dispatch);
        wr.push_back(t.write);
        tc.push_back(t.total_cpu);
        tw.push_back(t.total_wall);
    }
    report("frame_read_cpu", rd);
    report("frame_init_cpu", in);
    report("frame_dispatch_cpu", di);
    report("frame_write_cpu", wr);
    report("frame_cpu", tc);
    report("frame_wall", tw);
    return 0;
}
