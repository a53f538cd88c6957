// What lets the kernel sources compile both for Vitis HLS and, as the C simulation, with g++:
// HLS pragmas are emitted only under synthesis (__SYNTHESIS__), where g++ would warn about
// unknown pragmas.
#pragma once

#define RBDGRAD_HLS_STRINGIFY(x) #x
#if defined(__SYNTHESIS__)
#define RBDGRAD_HLS_PRAGMA(x) _Pragma(RBDGRAD_HLS_STRINGIFY(x))
#else
#define RBDGRAD_HLS_PRAGMA(x)
#endif
