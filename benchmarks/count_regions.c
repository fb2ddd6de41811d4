/* Counts the OpenMP parallel regions a program opens (GCC's libgomp entry points), for the thread
 * policy's measurements: LD_PRELOAD=./count_regions.so program ... prints at exit
 * "regions: N (threads asked: T)" on stderr. Build: cc -O2 -shared -fPIC count_regions.c
 * -o count_regions.so -ldl */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>

static atomic_long regions, threads_asked;

/* libgomp's own entry: the next definition, or libgomp's where it was loaded with RTLD_LOCAL (a
 * Python extension's). */
static void* gomp(const char* name) {
  void* f = dlsym(RTLD_NEXT, name);
  if (!f) {
    void* lib = dlopen("libgomp.so.1", RTLD_NOW | RTLD_NOLOAD);
    if (lib) f = dlsym(lib, name);
  }
  return f;
}

static void report(void) __attribute__((destructor));
static void report(void) {
  fprintf(stderr, "regions: %ld (threads asked: %ld)\n", (long)regions, (long)threads_asked);
}

void GOMP_parallel(void (*fn)(void*), void* data, unsigned num_threads, unsigned flags) {
  static void (*next)(void (*)(void*), void*, unsigned, unsigned);
  if (!next) next = gomp("GOMP_parallel");
  ++regions;
  threads_asked += num_threads;
  next(fn, data, num_threads, flags);
}

void GOMP_parallel_loop_dynamic(void (*fn)(void*), void* data, unsigned num_threads, long start,
                                long end, long incr, long chunk, unsigned flags) {
  static void (*next)(void (*)(void*), void*, unsigned, long, long, long, long, unsigned);
  if (!next) next = gomp("GOMP_parallel_loop_dynamic");
  ++regions;
  threads_asked += num_threads;
  next(fn, data, num_threads, start, end, incr, chunk, flags);
}
