// Execution-space annotation for code shared by the CPU engine and the GPU engine (force laws,
// wall geometry, vectors, quaternions, rigid rotation). Under nvcc a function marked BIODEM_HD
// compiles for both host and device; for g++ (the CPU engine, and the GPU engine's kernels run
// on CPU threads through Thrust's OpenMP backend in the tests) the macro is empty.
// constexpr functions need no mark: the CUDA build passes --expt-relaxed-constexpr.
#pragma once

#if defined(__CUDACC__)
#define BIODEM_HD __host__ __device__
#else
#define BIODEM_HD
#endif
