/* LRR__PRIVATE_API: what marks the private entry points liblrr exports for liblrr_mpi alone
 * (lib/solve/rows.h, lib/operator/build.h, lib/reference/rows.h; node LRR_PRIVATE_N of
 * lib/liblrr.map, checked by tests/abi.sh). */
#ifndef LRR_CORE_PRIVATE_API_H
#define LRR_CORE_PRIVATE_API_H

#if defined(__GNUC__) && __GNUC__ >= 4
#define LRR__PRIVATE_API __attribute__((visibility("default")))
#else
#define LRR__PRIVATE_API
#endif

#endif
