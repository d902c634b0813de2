// PF_HD marks a function that CUDA code may call on the device too; in a
// host-only compiler it is empty.
#ifndef POINTFORWARD_COMMON_HOST_DEVICE_H_
#define POINTFORWARD_COMMON_HOST_DEVICE_H_

#if defined(__CUDACC__)
#define PF_HD __host__ __device__
#else
#define PF_HD
#endif

#endif  // POINTFORWARD_COMMON_HOST_DEVICE_H_
