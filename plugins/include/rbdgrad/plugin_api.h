/* The rbdgrad backend plugin ABI: the one contract between the daemon and its backends.
 *
 * A backend is a shared library that exports one C function, rbdgrad_plugin_entry, returning a
 * table of function pointers. The daemon dlopen()s it with RTLD_NOW | RTLD_LOCAL.
 *
 * Versioning. RBDGRAD_PLUGIN_API_MAJOR changes break compatibility; MINOR changes only add to the
 * end of the structs below (each struct starts with its own size so either side can tell what the
 * other knows). The host passes its version to rbdgrad_plugin_entry; a plugin returns NULL when
 * the host's major differs from its own or the host's minor is lower than the one it needs, and
 * the host refuses a table whose api_major differs from its own. Both sides say why in their logs.
 *
 * Errors. Every call that can fail returns an rbdgrad_error*, NULL meaning success; the caller owns
 * a non-NULL error and releases it with the table's error_delete. No C++ exception crosses this
 * boundary: plugins catch everything at the entry points.
 *
 * Ownership and threads. The host owns every buffer it passes (model description, batch arrays);
 * the plugin owns instances until destroy_instance. get_info, can_run, create_instance and the
 * error_* functions may be called from any thread at any time; compute is never called
 * concurrently on the same instance, but different instances may compute concurrently. On failure
 * create_instance leaves *instance untouched and keeps nothing allocated.
 *
 * Data layout. A batch holds n states. Per-state vectors are nv scalars, matrices nv x nv ROW-MAJOR
 * (element (i, j) at i*nv + j; d(a)/d(b) has row i = a_i, column j = b_j); state k's vector starts at
 * k*nv, its matrix at k*nv*nv. The scalar type is the batch's precision: double (F64), float (F32)
 * or int32_t holding Q16.16 fixed point (FIXED_Q16_16, value = raw / 65536). Joint order is the
 * model's (Pinocchio's depth-first order).
 */
#ifndef RBDGRAD_PLUGIN_API_H_
#define RBDGRAD_PLUGIN_API_H_

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define RBDGRAD_PLUGIN_API_MAJOR 1
#define RBDGRAD_PLUGIN_API_MINOR 3

/* Precisions, usable as bit flags in rbdgrad_plugin_info.precisions. */
typedef enum rbdgrad_precision {
  RBDGRAD_PRECISION_F64 = 1,
  RBDGRAD_PRECISION_F32 = 2,
  RBDGRAD_PRECISION_FIXED_Q16_16 = 4
} rbdgrad_precision;

/* Outputs, usable as bit flags in rbdgrad_batch.outputs and rbdgrad_plugin_info.outputs. */
typedef enum rbdgrad_output {
  RBDGRAD_OUTPUT_QDD = 1,        /* (nv)      forward dynamics                          */
  RBDGRAD_OUTPUT_MINV = 2,       /* (nv x nv) M^-1                                       */
  RBDGRAD_OUTPUT_DQDD_DQ = 4,    /* (nv x nv) d qdd / d q                                */
  RBDGRAD_OUTPUT_DQDD_DQD = 8,   /* (nv x nv) d qdd / d qd                               */
  RBDGRAD_OUTPUT_TAU = 16,       /* (nv)      RNEA(q, qd, qdd)                           */
  RBDGRAD_OUTPUT_DTAU_DQ = 32,   /* (nv x nv) d tau / d q at (q, qd, qdd)                */
  RBDGRAD_OUTPUT_DTAU_DQD = 64,  /* (nv x nv) d tau / d qd                               */
  RBDGRAD_OUTPUT_M = 128         /* (nv x nv) joint-space inertia matrix                 */
} rbdgrad_output;

typedef enum rbdgrad_input_kind {
  RBDGRAD_INPUT_TAU = 0, /* batch.u holds tau: qdd = FD(q, qd, tau) is computed first */
  RBDGRAD_INPUT_QDD = 1  /* batch.u holds qdd                                         */
} rbdgrad_input_kind;

/* Error codes. Passed as uint32_t (error_code, state_status) so that a host can receive a code
 * added by a later minor version without undefined behaviour; unknown codes mean INTERNAL. */
typedef enum rbdgrad_error_code {
  RBDGRAD_OK = 0,                        /* only in state_status: the state was computed        */
  RBDGRAD_ERROR_INVALID_ARGUMENT = 1,    /* a bad request: sizes, values, unsupported option    */
  RBDGRAD_ERROR_UNSUPPORTED = 2,         /* this backend cannot run this (precision, outputs, N) */
  RBDGRAD_ERROR_NUMERICAL = 3,           /* singular M, overflow, NaN/Inf in a result            */
  RBDGRAD_ERROR_UNAVAILABLE = 4,         /* the device is missing or busy                        */
  RBDGRAD_ERROR_INTERNAL = 5,            /* a bug                                                */
  /* (1.1) in state_status of a FIXED_Q16_16 batch: the state left the format's range (its outputs
   * are not a result); the host may compute it again in floating point. Plugins send it only to
   * hosts of minor >= 1 and NUMERICAL to older ones. */
  RBDGRAD_ERROR_OUT_OF_RANGE = 6
} rbdgrad_error_code;

typedef struct rbdgrad_error rbdgrad_error;       /* opaque, owned by the plugin that made it */
typedef struct rbdgrad_instance rbdgrad_instance; /* opaque: one model on one backend          */

/* What a backend can do, filled by get_info. Strings stay valid while the library is loaded. */
typedef struct rbdgrad_plugin_info {
  size_t struct_size;     /* set by the caller to sizeof(rbdgrad_plugin_info) */
  const char* name;       /* "cpu", "cuda", "fpga"                             */
  const char* version;    /* the plugin's own version                          */
  uint32_t precisions;    /* rbdgrad_precision flags                           */
  uint32_t outputs;       /* rbdgrad_output flags                              */
  uint64_t max_batch;     /* largest n per compute call; 0 = no limit          */
  uint32_t max_nv;        /* largest model; 0 = no limit                       */
} rbdgrad_plugin_info;

/* (1.3) What every batch of an instance computes: a scene's execution plan (issue 8), fixed when
 * the instance is created so that the backend can build code without the stages it excludes. The
 * host sends only batches that follow it: outputs a non-empty subset of `outputs`, batch.minv
 * non-NULL exactly when minv_supplied, batch.fext NULL when fext_body_count is 0 and otherwise
 * NULL (no forces at all) or zero on every body not listed (a backend never reads those). A
 * backend refuses another batch with INVALID_ARGUMENT. */
typedef struct rbdgrad_plan {
  size_t struct_size;           /* sizeof(rbdgrad_plan)                                          */
  uint32_t outputs;             /* rbdgrad_output flags: what the batches may ask for            */
  uint32_t minv_supplied;       /* 1: every batch brings M^-1(q) in batch.minv; 0: none does     */
  uint32_t fext_body_count;     /* bodies that receive external forces; 0 = no external forces   */
  const uint32_t* fext_bodies;  /* fext_body_count bodies, ascending, each < nv                   */
} rbdgrad_plan;

/* A robot model in the core library's internal form (joint axes along each joint frame's z). Arrays
 * have nv entries (times 3 or 9 for vectors and row-major 3x3 matrices). */
typedef struct rbdgrad_model_desc {
  size_t struct_size;            /* sizeof(rbdgrad_model_desc)                                  */
  const char* name;
  uint32_t nv;
  const int32_t* parent;         /* parent joint, -1 for the world; parent[i] < i               */
  const uint8_t* joint_type;     /* 0 revolute about z, 1 prismatic along z                      */
  const double* joint_rotation;  /* 9 per joint: joint frame in the parent body frame, row-major */
  const double* joint_translation; /* 3 per joint                                               */
  const double* mass;            /* kg                                                          */
  const double* com;             /* 3 per body, body frame, m                                   */
  const double* inertia_com;     /* 9 per body, about the centre of mass, kg m^2, row-major      */
  const double* link_rotation;   /* 9 per body: URDF link frame to body frame (external forces)  */
  double gravity[3];             /* world frame, m/s^2                                          */
  /* (1.3) The plan every batch of an instance made from this description follows; NULL = batches
   * as they come. Read only when struct_size covers it: a 1.2 host's description ends above. */
  const rbdgrad_plan* plan;
} rbdgrad_model_desc;

/* Key/value options for an instance (e.g. "threads" = "4"); unknown keys are an error. */
typedef struct rbdgrad_options {
  size_t struct_size; /* sizeof(rbdgrad_options) */
  size_t count;
  const char* const* keys;
  const char* const* values;
} rbdgrad_options;

/* One batch. Inputs are read-only; an output pointer is written when its flag is in `outputs`
 * and may be NULL otherwise. */
typedef struct rbdgrad_batch {
  size_t struct_size;       /* sizeof(rbdgrad_batch)                                         */
  uint64_t n;               /* number of states, >= 1                                        */
  uint32_t precision;       /* one rbdgrad_precision                                         */
  uint32_t input_kind;      /* rbdgrad_input_kind                                            */
  uint32_t outputs;         /* rbdgrad_output flags, at least one                            */
  const void* q;            /* n x nv                                                        */
  const void* qd;           /* n x nv                                                        */
  const void* u;            /* n x nv, tau or qdd as input_kind says                         */
  const void* minv;         /* optional n x nv x nv caller-supplied M^-1, or NULL            */
  const void* fext;         /* optional n x nv x 6 external forces: per body [moment; force] in
                               its URDF link frame, about the link origin; or NULL          */
  void* qdd;                /* n x nv                                                        */
  void* minv_out;           /* n x nv x nv                                                   */
  void* dqdd_dq;            /* n x nv x nv                                                   */
  void* dqdd_dqd;           /* n x nv x nv                                                   */
  void* tau;                /* n x nv                                                        */
  void* dtau_dq;            /* n x nv x nv                                                   */
  void* dtau_dqd;           /* n x nv x nv                                                   */
  void* m;                  /* n x nv x nv                                                   */
  int32_t* state_status;    /* optional n entries: 0 = computed, else an rbdgrad_error_code  */
} rbdgrad_batch;

/* (1.1) What one instance runs on, filled by describe_instance. Strings stay valid while the
 * instance lives. */
typedef struct rbdgrad_instance_info {
  size_t struct_size;  /* set by the caller to sizeof(rbdgrad_instance_info)                        */
  const char* mode;    /* "" when the backend runs as itself; else how it stands in, e.g. "csim"
                          (the FPGA kernel's C simulation on the host CPU)                          */
  const char* device;  /* the device it runs on, for logs: "NVIDIA H200 (device 0)"; "" = unnamed.
                          It names the hardware only: a host may key measurements by it          */
  /* (1.2) more on how it runs, for logs: "kernel compiled for this robot (f64: disk cache, ...)";
   * "" = nothing. Written only when struct_size covers it (a 1.1 host passes the shorter struct). */
  const char* detail;
} rbdgrad_instance_info;

typedef struct rbdgrad_plugin_api {
  size_t struct_size;   /* sizeof(rbdgrad_plugin_api) as the plugin was built */
  uint32_t api_major;   /* RBDGRAD_PLUGIN_API_MAJOR the plugin was built with */
  uint32_t api_minor;

  rbdgrad_error* (*get_info)(rbdgrad_plugin_info* info);

  /* Whether this backend can run a batch of n states of this model in this precision with these
   * outputs: NULL if yes, else an error saying why (RBDGRAD_ERROR_UNSUPPORTED or _UNAVAILABLE;
   * INVALID_ARGUMENT for a malformed question). Lets the scheduler route instead of failing. */
  rbdgrad_error* (*can_run)(const rbdgrad_model_desc* model, uint32_t precision, uint32_t outputs, uint64_t n);

  /* Prepares a model: validates it, allocates every workspace (compute then never allocates). */
  rbdgrad_error* (*create_instance)(const rbdgrad_model_desc* model, const rbdgrad_options* options,
                                    rbdgrad_instance** instance);

  /* Computes a batch into the caller's buffers. On a per-state failure (e.g. a singular M) the
   * other states are still computed; state_status says which failed and the returned error
   * names the first of them ("state 3: ..."). The outputs of a failed state are unspecified.
   * With a caller-supplied M^-1, the derivatives use it and the MINV output (when requested) is
   * M^-1(q) computed by the backend. */
  rbdgrad_error* (*compute)(rbdgrad_instance* instance, const rbdgrad_batch* batch);

  void (*destroy_instance)(rbdgrad_instance* instance);

  uint32_t (*error_code)(const rbdgrad_error* error);       /* an rbdgrad_error_code; 0 for NULL */
  const char* (*error_message)(const rbdgrad_error* error); /* valid until error_delete */
  void (*error_delete)(rbdgrad_error* error);

  /* (1.1) Describes an instance; may be NULL (nothing to say). Any thread, any time. */
  rbdgrad_error* (*describe_instance)(const rbdgrad_instance* instance, rbdgrad_instance_info* info);

  /* (1.2) The backend's own prediction of one compute call's time, in microseconds, for n states in
   * `precision` from `input_kind`, the gradient outputs (qdd, d qdd/d q, d qdd/d qd) asked: for a
   * backend with a model of hardware that running it here would not measure (the FPGA's cycle
   * count while its kernel runs as a C simulation). May be NULL; RBDGRAD_ERROR_UNSUPPORTED also
   * means no model: the host then times the backend itself (calibration). Any thread, any time. */
  rbdgrad_error* (*estimate_latency)(const rbdgrad_instance* instance, uint32_t precision, uint32_t input_kind,
                                     uint64_t n, double* microseconds);
} rbdgrad_plugin_api;

/* The one exported symbol. Returns NULL when the host's API version is not compatible. */
typedef const rbdgrad_plugin_api* (*rbdgrad_plugin_entry_fn)(uint32_t host_api_major, uint32_t host_api_minor);
#define RBDGRAD_PLUGIN_ENTRY_SYMBOL "rbdgrad_plugin_entry"

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* RBDGRAD_PLUGIN_API_H_ */
