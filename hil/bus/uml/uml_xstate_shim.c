/*
 * LD_PRELOAD shim for Debian's user-mode-linux 6.1 on hosts with AVX-512/AMX.
 *
 * Why: UML 6.1 saves and restores a guest thread's FPU state with
 * ptrace(PTRACE_{GET,SET}REGSET, NT_X86_XSTATE) into a fixed 832-byte buffer
 * (x87/SSE + AVX).  The host kernel accepts a short buffer for GET but
 * rejects a SET whose size is not the full XSAVE size (EFAULT), so on a CPU
 * with AVX-512 or AMX the first guest process dies with
 * "userspace - ptrace set fp regs failed, errno = 14" and the kernel panics.
 *
 * What: keep, per UML fp buffer (one per guest thread), a full-size copy of
 * the host XSAVE state.  GET fills the full copy and hands UML its prefix;
 * SET overlays UML's prefix on the full copy and writes the full size.  Every
 * other ptrace call passes through untouched.  No allocation happens in the
 * intercepted path (UML may call it from signal handlers): slots live in one
 * arena mapped at load time.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/ptrace.h>
#include <sys/syscall.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

#define NT_X86_XSTATE_NOTE 0x202
#define SLOT_BYTES (64 * 1024)   /* >= any host XSAVE size (AMX: ~11 KiB) */
#define SLOT_COUNT 2048           /* power of two; guest threads alive at once */

struct slot {
    void *owner;      /* UML's fp buffer address; NULL = free */
    size_t size;      /* valid bytes in data (host XSAVE size) */
    unsigned char *data;
};

static struct slot slots[SLOT_COUNT];
static unsigned char *arena;

__attribute__((constructor)) static void shim_init(void)
{
    arena = mmap(NULL, (size_t)SLOT_BYTES * SLOT_COUNT, PROT_READ | PROT_WRITE,
                 MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (arena == MAP_FAILED)
        arena = NULL;
}

static long raw_ptrace(long request, pid_t pid, void *addr, void *data)
{
    return syscall(SYS_ptrace, request, pid, addr, data);
}

/* Slot for UML buffer `owner`: open addressing on the pointer's hash. */
static struct slot *slot_for(void *owner)
{
    uintptr_t h = ((uintptr_t)owner >> 4) * 0x9E3779B97F4A7C15ull;
    for (unsigned i = 0; i < SLOT_COUNT; i++) {
        struct slot *s = &slots[(h + i) & (SLOT_COUNT - 1)];
        if (s->owner == owner)
            return s;
        if (s->owner == NULL) {
            s->owner = owner;
            s->size = 0;
            s->data = arena + (size_t)((s - slots)) * SLOT_BYTES;
            return s;
        }
    }
    return NULL; /* table full: caller falls back to pass-through */
}

static long full_get(pid_t pid, struct slot *s)
{
    struct iovec full = { s->data, SLOT_BYTES };
    long r = raw_ptrace(PTRACE_GETREGSET, pid, (void *)NT_X86_XSTATE_NOTE, &full);
    if (r == 0)
        s->size = full.iov_len;
    return r;
}

static long xstate_get(pid_t pid, struct iovec *iov)
{
    struct slot *s = slot_for(iov->iov_base);
    if (s == NULL)
        return raw_ptrace(PTRACE_GETREGSET, pid, (void *)NT_X86_XSTATE_NOTE, iov);
    long r = full_get(pid, s);
    if (r != 0)
        return r;
    size_t n = iov->iov_len < s->size ? iov->iov_len : s->size;
    memcpy(iov->iov_base, s->data, n);
    iov->iov_len = n;
    return 0;
}

static long xstate_set(pid_t pid, struct iovec *iov)
{
    struct slot *s = slot_for(iov->iov_base);
    if (s == NULL)
        return raw_ptrace(PTRACE_SETREGSET, pid, (void *)NT_X86_XSTATE_NOTE, iov);
    /* A buffer never read back (a new guest thread): start from the host
     * process's current state so the parts UML does not know stay valid. */
    if (s->size == 0 && full_get(pid, s) != 0)
        return -1;
    if (iov->iov_len >= s->size)
        return raw_ptrace(PTRACE_SETREGSET, pid, (void *)NT_X86_XSTATE_NOTE, iov);
    memcpy(s->data, iov->iov_base, iov->iov_len);
    struct iovec full = { s->data, s->size };
    return raw_ptrace(PTRACE_SETREGSET, pid, (void *)NT_X86_XSTATE_NOTE, &full);
}

long ptrace(enum __ptrace_request request, ...)
{
    va_list ap;
    va_start(ap, request);
    pid_t pid = va_arg(ap, pid_t);
    void *addr = va_arg(ap, void *);
    void *data = va_arg(ap, void *);
    va_end(ap);

    static long (*real)(enum __ptrace_request, ...);
    if (arena != NULL && (uintptr_t)addr == NT_X86_XSTATE_NOTE && data != NULL) {
        if (request == PTRACE_GETREGSET)
            return xstate_get(pid, data);
        if (request == PTRACE_SETREGSET)
            return xstate_set(pid, data);
    }
    if (real == NULL)
        real = (long (*)(enum __ptrace_request, ...))dlsym(RTLD_NEXT, "ptrace");
    return real(request, pid, addr, data);
}
