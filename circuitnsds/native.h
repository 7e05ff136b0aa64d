/* What every C library of circuitnsds shares (circuitnsds/native.py loads them with ctypes).
 *
 * setup.py builds each library with -DCIRCUITNSDS_SOURCE_DIGEST="<digest of its .c and of
 * this header>"; the library returns it from circuitnsds_source_digest(), and
 * circuitnsds.native refuses a library whose digest is not that of the sources beside it.
 */
#ifndef CIRCUITNSDS_NATIVE_H
#define CIRCUITNSDS_NATIVE_H

#ifndef CIRCUITNSDS_SOURCE_DIGEST
#error "build with -DCIRCUITNSDS_SOURCE_DIGEST=\"<digest>\" (setup.py does)"
#endif

#if defined(_WIN32)
#define EXPORT __declspec(dllexport)
#else
#define EXPORT __attribute__((visibility("default")))
#endif

EXPORT const char *circuitnsds_source_digest(void) { return CIRCUITNSDS_SOURCE_DIGEST; }

#endif
