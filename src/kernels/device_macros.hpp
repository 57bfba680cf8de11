#pragma once
// Marks functions that target regions call. Only an offload build needs the declare-target pragmas;
// elsewhere they expand to nothing so host builds carry no OpenMP-target baggage.
#if defined(CAPSFLOW_HAVE_OFFLOAD)
#define CAPSFLOW_DEVICE_BEGIN _Pragma("omp declare target")
#define CAPSFLOW_DEVICE_END _Pragma("omp end declare target")
#else
#define CAPSFLOW_DEVICE_BEGIN
#define CAPSFLOW_DEVICE_END
#endif
