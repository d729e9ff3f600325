/* SPDX-License-Identifier: BSD-3-Clause */
/* io/out_file.c — atomic output files: written under a temporary name beside the output and
 * renamed when complete; a fixed registry of the temporary names, so that the outputs of one
 * run are renamed together (held) and a signal can remove them (POSIX rename, unlink). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "io_util.h"
#include "volmesh/io.h"

/* The outputs being written or held at once: a run writes a handful (mesh, surface, report
 * and its pictures); beyond this the files still work, unregistered. */
enum { SLOTS = 32 };
enum { FREE = 0, CLAIMED, LIVE, HELD };

/* One temporary file. state is the only field a signal handler trusts: tmp is complete
 * whenever state is LIVE or HELD. */
typedef struct {
    atomic_int state;
    unsigned long seq; /* order of opening, for the held renames */
    char tmp[sizeof(((vm_outfile *)0)->tmp_path)];
    char final[sizeof(((vm_outfile *)0)->final_path)];
} slot;

static slot slots[SLOTS];
static unsigned long next_seq;

/* The outputs whose renames wait for vm_output_commit (declared by vm_output_hold). */
enum { HOLD_MAX = 16 };
static char *held_paths[HOLD_MAX];
static size_t nheld_paths;

/* A free slot for tmp/final, or -1 when all are taken. */
static int slot_claim(const char *tmp, const char *final) {
    for (int i = 0; i < SLOTS; i++) {
        int expect = FREE;
        if (atomic_compare_exchange_strong(&slots[i].state, &expect, CLAIMED)) {
            strcpy(slots[i].tmp, tmp);
            strcpy(slots[i].final, final);
            slots[i].seq = next_seq++;
            atomic_store(&slots[i].state, LIVE);
            return i;
        }
    }
    return -1;
}

static void slot_free(int i) {
    if (i >= 0) atomic_store(&slots[i].state, FREE);
}

/* 1 when path is one of the outputs vm_output_hold declared. */
static int is_held(const char *path) {
    for (size_t i = 0; i < nheld_paths; i++)
        if (strcmp(held_paths[i], path) == 0) return 1;
    return 0;
}

#ifndef NAME_MAX
#define NAME_MAX 255 /* POSIX's least is 14; Linux, macOS and the BSDs have 255 */
#endif

int vm__temp_path(const char *path, const char *tag, char *out, size_t cap) {
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    size_t dir_len = (size_t)(base - path);
    char suffix[48];
    snprintf(suffix, sizeof suffix, ".%s-%ld", tag, (long)getpid());
    int n;
    if (strlen(base) + strlen(suffix) <= NAME_MAX) {
        n = snprintf(out, cap, "%s%s", path, suffix);
    } else {
        /* too long a name with the suffix: a hidden name from a hash of it (FNV-1a 64) */
        uint64_t h = 14695981039346656037ull;
        for (const char *c = base; *c; c++) h = (h ^ (unsigned char)*c) * 1099511628211ull;
        n = snprintf(out, cap, "%.*s.vm-%016llx%s", (int)dir_len, path, (unsigned long long)h,
                     suffix);
    }
    return n > 0 && (size_t)n < cap;
}

vm_status vm__out_open(vm_outfile *o, const char *path, vm_error *err) {
    memset(o, 0, sizeof *o);
    o->slot = -1;
    if (strlen(path) >= sizeof o->final_path ||
        !vm__temp_path(path, "tmp", o->tmp_path, sizeof o->tmp_path))
        return vm_error_set(err, VM_ERR_ARG, "%s: path too long", path);
    strcpy(o->final_path, path);
    o->slot = slot_claim(o->tmp_path, o->final_path);
    if (o->slot < 0 && is_held(path))
        return vm_error_set(err, VM_ERR_IO, "%s: too many output files at once", path);
    o->fp = fopen(o->tmp_path, "wb");
    if (!o->fp) {
        int e = errno;
        slot_free(o->slot);
        o->slot = -1;
        return vm_error_set(err, VM_ERR_IO, "%s: cannot write (%s)", path, strerror(e));
    }
    return VM_OK;
}

/* The reason a stream failed, or 0: a stream whose error flag is set lost the errno of the
 * write that failed, so one more byte is written to learn it again (the file is removed
 * anyway). The data reaches the disk (fsync) before the file may be renamed over an older
 * one, so that a crash never leaves an empty or partial file under the output's name. */
static int stream_error(FILE *fp) {
    if (ferror(fp)) {
        clearerr(fp);
        errno = 0;
        if (fputc(0, fp) == EOF || fflush(fp) != 0) return errno ? errno : EIO;
        return EIO;
    }
    if (fflush(fp) != 0) return errno ? errno : EIO;
    if (fsync(fileno(fp)) != 0 && errno != EINVAL && errno != EROFS) return errno;
    return 0;
}

vm_status vm__out_commit(vm_outfile *o, vm_error *err) {
    vm__meter_end(&o->meter);
    if (vm__meter_stopped(&o->meter)) { /* the progress callback cancelled: no file */
        vm__out_abort(o);
        return vm__cancelled(err, o->final_path);
    }
    int e = stream_error(o->fp);
    if (fclose(o->fp) != 0 && !e) e = errno ? errno : EIO;
    o->fp = NULL;
    if (e) {
        remove(o->tmp_path);
        slot_free(o->slot);
        return vm_error_set(err, VM_ERR_IO, "%s: write failed (%s)", o->final_path,
                            strerror(e));
    }
    if (o->slot >= 0 && is_held(o->final_path)) {
        /* complete: renamed with the run's other outputs by vm_output_commit */
        atomic_store(&slots[o->slot].state, HELD);
        return VM_OK;
    }
    if (rename(o->tmp_path, o->final_path) != 0) {
        e = errno;
        remove(o->tmp_path);
        slot_free(o->slot);
        return vm_error_set(err, VM_ERR_IO, "%s: cannot write (%s)", o->final_path,
                            strerror(e));
    }
    slot_free(o->slot);
    return VM_OK;
}

void vm__out_meter(vm_outfile *o, vm_progress_fn fn, void *user, double total) {
    vm__meter_start(&o->meter, fn, user, "write", total);
}

void vm__out_abort(vm_outfile *o) {
    if (o->fp) fclose(o->fp);
    o->fp = NULL;
    if (o->tmp_path[0]) remove(o->tmp_path);
    slot_free(o->slot);
    o->slot = -1;
}

/* ---- the outputs of a run ------------------------------------------------------------- */

vm_status vm_output_check(const char *path, vm_error *err) {
    if (!path || !path[0]) return vm_error_set(err, VM_ERR_ARG, "output file name is empty");
    size_t len = strlen(path);
    if (len >= sizeof(((vm_outfile *)0)->final_path))
        return vm_error_set(err, VM_ERR_ARG, "%s: path too long", path);
    if (path[len - 1] == '/')
        return vm_error_set(err, VM_ERR_IO, "%s: is a folder, not a file", path);
    struct stat sb;
    if (stat(path, &sb) == 0 && S_ISDIR(sb.st_mode))
        return vm_error_set(err, VM_ERR_IO, "%s: is a folder, not a file", path);
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash)
        strcpy(dir, ".");
    else if (slash == path)
        strcpy(dir, "/");
    else
        snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    if (stat(dir, &sb) != 0)
        return vm_error_set(err, VM_ERR_IO, "%s: folder %s does not exist (%s)", path, dir,
                            strerror(errno));
    if (!S_ISDIR(sb.st_mode))
        return vm_error_set(err, VM_ERR_IO, "%s: %s is not a folder", path, dir);
    if (access(dir, W_OK | X_OK) != 0)
        return vm_error_set(err, VM_ERR_IO, "%s: cannot write in folder %s (%s)", path, dir,
                            strerror(errno));
    return VM_OK;
}

vm_status vm_output_hold(const char *path, vm_error *err) {
    if (is_held(path)) return VM_OK;
    size_t len = strlen(path);
    char *copy = nheld_paths < HOLD_MAX ? malloc(len + 1) : NULL;
    if (!copy)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: cannot hold more than %d outputs", path,
                            HOLD_MAX);
    memcpy(copy, path, len + 1);
    held_paths[nheld_paths++] = copy;
    return VM_OK;
}

/* Forgets the declared outputs. */
static void release_holds(void) {
    for (size_t i = 0; i < nheld_paths; i++) free(held_paths[i]);
    nheld_paths = 0;
}

vm_status vm_output_commit(vm_error *err) {
    vm_status st = VM_OK;
    for (;;) { /* the held files in the order they were opened */
        int best = -1;
        for (int i = 0; i < SLOTS; i++)
            if (atomic_load(&slots[i].state) == HELD &&
                (best < 0 || slots[i].seq < slots[best].seq))
                best = i;
        if (best < 0) break;
        slot *s = &slots[best];
        if (st == VM_OK && rename(s->tmp, s->final) != 0)
            st = vm_error_set(err, VM_ERR_IO, "%s: cannot write (%s)", s->final,
                              strerror(errno));
        if (st != VM_OK) unlink(s->tmp); /* after a failed rename, none of the rest */
        slot_free(best);
    }
    release_holds();
    return st;
}

void vm_output_discard(void) {
    for (int i = 0; i < SLOTS; i++)
        if (atomic_load(&slots[i].state) == HELD) {
            unlink(slots[i].tmp);
            slot_free(i);
        }
    release_holds();
}

vm_status vm_output_write(const char *path, vm_output_write_fn write, void *user,
                          vm_error *err) {
    vm_outfile o;
    vm_status st = vm__out_open(&o, path, err);
    if (st) return st;
    if (err) err->message[0] = '\0';
    if (write(o.fp, user, err) != 0) {
        vm__out_abort(&o);
        if (err && err->message[0]) return err->status ? err->status : VM_ERR_IO;
        return vm_error_set(err, VM_ERR_IO, "%s: write failed", path);
    }
    return vm__out_commit(&o, err);
}

int vm__temp_track(const char *tmp) {
    return strlen(tmp) < sizeof slots[0].tmp ? slot_claim(tmp, "") : -1;
}

void vm__temp_untrack(int id) { slot_free(id); }

/* ---- signals ---------------------------------------------------------------------------- */

/* Removes every temporary output file and ends the process with 128 + sig, as a shell
 * reports a process killed by sig. Only async-signal-safe calls: atomic loads, unlink,
 * _exit (POSIX.1-2017, 2.4.3). */
static void on_signal(int sig) {
    for (int i = 0; i < SLOTS; i++) {
        int st = atomic_load(&slots[i].state);
        if (st == LIVE || st == HELD) unlink(slots[i].tmp);
    }
    _exit(128 + sig);
}

void vm_output_remove_on_signals(void) {
    static const int sigs[] = {SIGINT, SIGTERM};
    for (size_t k = 0; k < sizeof sigs / sizeof sigs[0]; k++) {
        struct sigaction old, sa;
        /* a signal ignored when the program started stays ignored (a background job's
         * SIGINT, nohup) */
        if (sigaction(sigs[k], NULL, &old) == 0 && old.sa_handler == SIG_IGN) continue;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_signal;
        sigfillset(&sa.sa_mask);
        sigaction(sigs[k], &sa, NULL);
    }
}
