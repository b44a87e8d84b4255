/* output.c - output files that appear whole or not at all, written as what their path names
 * demands (bst_output_*; the CLI and bst_bsdf_write_path use them).
 *
 * What PATH names decides how it is written:
 *   a regular file, or nothing yet   a temporary beside it, renamed over it on commit (atomic);
 *                                    an existing file keeps its mode and, where we may, its owner,
 *                                    a new one gets 0666 & ~umask as fopen would give it
 *   a symbolic link (chain)          the same beside the file the links lead to: the links stay
 *   a device, FIFO or socket         opened and written directly, no temporary
 *   a directory                      an error
 *
 * A temporary is PATH.tmpXXXXXX (mkstemp) beside the file renamed over, and its writer holds an
 * exclusive flock on it until it is renamed or removed, so that bst_output_clean can tell the
 * temporaries of writers that were killed (no lock: removed) from those being written (locked).
 *
 * Two paths write one file when bst_output_key gives them one key: the file's identity (device
 * and inode, through any links), or, for a file not there yet, the identity of the directory it
 * will be created in and its name there.  Names are compared as bytes. */
#include <config.h>

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ctx.h"

#define OUTPUT_MAX_LINKS 40 /* symbolic links followed before giving up (ELOOP), as Linux does */
#define OUTPUT_TMP_SUFFIX ".tmpXXXXXX"
#define OUTPUT_TMP_TRIES 8  /* temporaries made again when a cleaner took one before its lock */

struct bst_output {
    bst_ctx *ctx;
    FILE *fp;
    char *path;   /* as given, for messages */
    char *target; /* where the links of path lead (the file renamed over), or NULL */
    char *tmp;    /* the temporary beside target, or NULL when written directly */
};

/* The target of the symbolic link at path; NULL with errno set. */
static char *read_link(bst_ctx *ctx, const char *path)
{
    for (size_t size = 256;; size *= 2) {
        char *buf = bsti_malloc(ctx, size);
        if (!buf) {
            errno = ENOMEM;
            return NULL;
        }
        ssize_t n = readlink(path, buf, size);
        if (n < 0) {
            int e = errno;
            bsti_free(ctx, buf);
            errno = e;
            return NULL;
        }
        if ((size_t)n < size) {
            buf[n] = '\0';
            return buf;
        }
        bsti_free(ctx, buf);
    }
}

/* The path that path's chain of symbolic links finally names (which need not exist yet), each
 * relative link taken from the directory holding the link; NULL with errno set. */
static char *follow_links(bst_ctx *ctx, const char *path)
{
    char *cur = bsti_strdup(ctx, path);
    if (!cur)
        errno = ENOMEM;
    for (int hops = 0; cur; hops++) {
        struct stat st;
        if (lstat(cur, &st) != 0 || !S_ISLNK(st.st_mode))
            return cur; /* not there (yet), or not a link: later steps report what is wrong */
        char *link = hops < OUTPUT_MAX_LINKS ? read_link(ctx, cur) : NULL;
        if (!link) {
            int e = hops < OUTPUT_MAX_LINKS ? errno : ELOOP;
            bsti_free(ctx, cur);
            errno = e;
            return NULL;
        }
        const char *slash = strrchr(cur, '/');
        size_t dirlen = link[0] == '/' || !slash ? 0 : (size_t)(slash - cur) + 1;
        char *next = bsti_malloc(ctx, dirlen + strlen(link) + 1);
        if (next) {
            memcpy(next, cur, dirlen);
            strcpy(next + dirlen, link);
        } else {
            errno = ENOMEM;
        }
        bsti_free(ctx, link);
        bsti_free(ctx, cur);
        cur = next;
    }
    return NULL;
}

/* Open o->path directly (a device, FIFO or socket): the kernel follows any links. */
static int open_direct(bst_output *o)
{
    int fd = open(o->path, O_WRONLY | O_NOCTTY);
    if (fd < 0)
        return bsti_error(o->ctx, BST_EIO, "%s: cannot open for writing: %s", o->path, strerror(errno));
    if (!(o->fp = fdopen(fd, "w"))) {
        int e = errno;
        close(fd);
        return bsti_error(o->ctx, BST_EIO, "%s: cannot open for writing: %s", o->path, strerror(e));
    }
    return BST_OK;
}

/* Why the temporary beside o->target could not be made (err: mkstemp's errno), naming the call
 * that failed: the temporary is created, not PATH, so "PATH: No such file or directory" for a PATH
 * that exists misled.  ENOENT is a missing directory, or one whose file system makes no new files
 * (/proc, where only the existing entries are): the message says which. */
static int temporary_error(bst_output *o, int err)
{
    char dir[4096], note[sizeof dir + 64] = "";
    const char *slash = strrchr(o->target, '/');
    size_t dirlen = slash ? (size_t)(slash - o->target) + (slash == o->target) : 1;
    snprintf(dir, sizeof dir, "%.*s", (int)dirlen, slash ? o->target : ".");
    struct stat st;
    if (err == ENOENT && stat(dir, &st) != 0)
        return bsti_error(o->ctx, BST_EIO, "%s: cannot create output file: %s: %s", o->path, dir,
                          strerror(errno));
    if (err == ENOENT && S_ISDIR(st.st_mode))
        snprintf(note, sizeof note, " (%s exists, but its file system makes no new files)", dir);
    return bsti_error(o->ctx, BST_EIO, "%s: cannot create output file: its temporary %s"
                      OUTPUT_TMP_SUFFIX ": %s%s", o->path, o->target, strerror(err), note);
}

/* A temporary beside o->target, with the permissions (and owner) of old, the regular file it will
 * replace, or those of a new file when old is NULL. */
static int open_temporary(bst_output *o, const struct stat *old)
{
    size_t n = strlen(o->target);
    if (!(o->tmp = bsti_malloc(o->ctx, n + 16)))
        return BST_ENOMEM;
    /* same directory: rename() is atomic.  Locked, and still ours under that name once locked:
     * a bst_output_clean that saw it before the lock holds it, removes it, and it is made again.
     * A file system without flock (ENOLCK, EOPNOTSUPP) leaves it unlocked. */
    int fd = -1, err = 0;
    for (int tries = 0; fd < 0 && tries < OUTPUT_TMP_TRIES; tries++) {
        snprintf(o->tmp, n + 16, "%s" OUTPUT_TMP_SUFFIX, o->target);
        if ((fd = mkstemp(o->tmp)) < 0) {
            err = errno;
            break;
        }
        struct stat mine, named;
        int locked = flock(fd, LOCK_EX | LOCK_NB) == 0;
        if (!locked && errno != EWOULDBLOCK)
            break;
        if (locked && fstat(fd, &mine) == 0 && stat(o->tmp, &named) == 0 &&
            mine.st_dev == named.st_dev && mine.st_ino == named.st_ino)
            break;
        close(fd); /* the cleaner's now, which removes it */
        fd = -1, err = EAGAIN;
    }
    if (fd < 0) {
        int rc = temporary_error(o, err);
        bsti_free(o->ctx, o->tmp);
        o->tmp = NULL;
        return rc;
    }
    if (old) {
        /* best effort: only root may give the file away; chown before chmod, which it may clear */
        if (fchown(fd, old->st_uid, old->st_gid) != 0) {
            /* the replacement is then ours, with the old permissions */
        }
        fchmod(fd, old->st_mode & 07777);
    } else {
        mode_t mask = umask(0); /* mkstemp creates 0600: give what a plain fopen would */
        umask(mask);
        fchmod(fd, 0666 & ~mask);
    }
    if (!(o->fp = fdopen(fd, "w"))) {
        int e = errno;
        close(fd);
        return bsti_error(o->ctx, BST_EIO, "%s: cannot open output file: %s", o->path, strerror(e));
    }
    return BST_OK;
}

int bst_output_open(bst_ctx *ctx, const char *path, bst_output **out)
{
    if (!ctx || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "output: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!path || !*path)
        return bsti_error(ctx, BST_EINVAL, "an empty output file name");
    bst_output *o = bsti_calloc(ctx, 1, sizeof *o);
    if (!o)
        return BST_ENOMEM;
    o->ctx = ctx;
    int rc = (o->path = bsti_strdup(ctx, path)) ? BST_OK : BST_ENOMEM;
    struct stat st; /* through any links */
    int exists = stat(path, &st) == 0;
    if (rc < 0) {
        /* reported */
    } else if (exists && S_ISDIR(st.st_mode)) {
        rc = bsti_error(ctx, BST_EIO, "%s: is a directory; name an output file", path);
    } else if (exists && !S_ISREG(st.st_mode)) {
        rc = open_direct(o);
    } else if (!(o->target = follow_links(ctx, path))) {
        rc = errno == ENOMEM ? BST_ENOMEM : bsti_error(ctx, BST_EIO, "%s: %s", path, strerror(errno));
    } else {
        rc = open_temporary(o, exists ? &st : NULL);
    }
    if (rc < 0) {
        bst_output_abort(o);
        return rc;
    }
    *out = o;
    return BST_OK;
}

/* ------------------------------------------------------------------ temporaries left behind */

/* An output for bst_output_clean: the directory its temporaries go in, by identity, and the name
 * of the file renamed over (a pointer into target, the path its links lead to). */
struct clean_item {
    dev_t dev;
    ino_t ino;
    char *target;
    const char *dir, *name;
};

static int by_dir_name(const void *a, const void *b)
{
    const struct clean_item *x = a, *y = b;
    if (x->dev != y->dev)
        return x->dev < y->dev ? -1 : 1;
    if (x->ino != y->ino)
        return x->ino < y->ino ? -1 : 1;
    return strcmp(x->name, y->name);
}

/* The name of the file whose temporary entry is (NAME.tmpXXXXXX, X from mkstemp's letters and
 * digits), cut in place into buf; NULL when entry is no temporary. */
static const char *temporary_of(const char *entry, char *buf, size_t size)
{
    size_t n = strlen(entry), k = sizeof OUTPUT_TMP_SUFFIX - 1;
    if (n <= k || n >= size || strncmp(entry + n - k, OUTPUT_TMP_SUFFIX, 4) != 0)
        return NULL;
    for (size_t i = n - 6; i < n; i++) {
        char c = entry[i];
        if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9')))
            return NULL;
    }
    memcpy(buf, entry, n - k);
    buf[n - k] = '\0';
    return buf;
}

/* Remove the temporary entry of directory dfd when no writer holds its lock; 1 when removed. */
static int remove_unlocked(int dfd, const char *entry)
{
    int fd = openat(dfd, entry, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0 && errno == EACCES)
        fd = openat(dfd, entry, O_WRONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return 0;
    struct stat held, named;
    int gone = fstat(fd, &held) == 0 && S_ISREG(held.st_mode) && flock(fd, LOCK_EX | LOCK_NB) == 0 &&
               fstatat(dfd, entry, &named, AT_SYMLINK_NOFOLLOW) == 0 && held.st_dev == named.st_dev &&
               held.st_ino == named.st_ino && unlinkat(dfd, entry, 0) == 0;
    close(fd);
    return gone;
}

int bst_output_clean(bst_ctx *ctx, size_t n, const char *const *paths, size_t *removed)
{
    if (removed)
        *removed = 0;
    if (!ctx || (n && !paths))
        return ctx ? bsti_error(ctx, BST_EINVAL, "output clean: NULL argument") : BST_EINVAL;
    struct clean_item *it = n ? bsti_alloc_array(ctx, n, sizeof *it) : NULL;
    if (n && !it)
        return BST_ENOMEM;
    size_t m = 0;
    int rc = BST_OK;
    for (size_t i = 0; i < n && rc == BST_OK; i++) {
        if (!paths[i] || !*paths[i])
            continue;
        char *target = follow_links(ctx, paths[i]);
        if (!target) {
            rc = errno == ENOMEM ? BST_ENOMEM : BST_OK; /* a loop of links: never written */
            continue;
        }
        char *slash = strrchr(target, '/');
        struct clean_item c = {.target = target, .dir = ".", .name = target};
        if (slash) {
            c.name = slash + 1;
            c.dir = slash == target ? "/" : target;
            *slash = '\0';
        }
        struct stat st;
        if (!*c.name || stat(c.dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
            bsti_free(ctx, target); /* nothing to look into: its write fails and says why */
            continue;
        }
        c.dev = st.st_dev, c.ino = st.st_ino;
        it[m++] = c;
    }
    if (rc == BST_OK)
        qsort(it, m, sizeof *it, by_dir_name);
    /* each directory read once; its temporaries looked up among the names that go in it */
    for (size_t g = 0, end; rc == BST_OK && g < m; g = end) {
        for (end = g + 1; end < m && it[end].dev == it[g].dev && it[end].ino == it[g].ino; end++)
            ;
        DIR *d = opendir(it[g].dir);
        if (!d)
            continue;
        struct dirent *de;
        char base[512];
        while ((de = readdir(d))) {
            struct clean_item key = {.dev = it[g].dev, .ino = it[g].ino};
            if (!(key.name = temporary_of(de->d_name, base, sizeof base)) ||
                !bsearch(&key, it + g, end - g, sizeof *it, by_dir_name))
                continue;
            if (remove_unlocked(dirfd(d), de->d_name) && removed)
                (*removed)++;
        }
        closedir(d);
    }
    for (size_t i = 0; i < m; i++)
        bsti_free(ctx, it[i].target);
    bsti_free(ctx, it);
    return rc;
}

int bst_output_key(bst_ctx *ctx, const char *path, char *key, size_t size)
{
    if (!ctx || !path || !key || size == 0)
        return ctx ? bsti_error(ctx, BST_EINVAL, "output key: NULL argument") : BST_EINVAL;
    key[0] = '\0';
    if (!*path)
        return bsti_error(ctx, BST_EINVAL, "an empty output file name");
    struct stat st;
    int n;
    if (stat(path, &st) == 0) {
        n = snprintf(key, size, "F %llu:%llu", (unsigned long long)st.st_dev,
                     (unsigned long long)st.st_ino);
    } else if (errno != ENOENT) {
        return bsti_error(ctx, BST_EIO, "%s: %s", path, strerror(errno));
    } else {
        /* not there yet: where the links lead, then that name in its directory */
        char *target = follow_links(ctx, path);
        if (!target)
            return errno == ENOMEM ? BST_ENOMEM : bsti_error(ctx, BST_EIO, "%s: %s", path, strerror(errno));
        char *slash = strrchr(target, '/');
        const char *name = slash ? slash + 1 : target, *dir = slash ? target : ".";
        if (slash == target)
            dir = "/";
        else if (slash)
            *slash = '\0';
        int e = !*name ? EISDIR : stat(dir, &st) != 0 ? errno : !S_ISDIR(st.st_mode) ? ENOTDIR : 0;
        n = e ? 0 : snprintf(key, size, "N %llu:%llu/%s", (unsigned long long)st.st_dev,
                             (unsigned long long)st.st_ino, name);
        bsti_free(ctx, target);
        if (e)
            return bsti_error(ctx, BST_EIO, "%s: %s", path, strerror(e));
    }
    if (n < 0 || (size_t)n >= size) {
        key[0] = '\0';
        return bsti_error(ctx, BST_EINVAL, "%s: the output key needs %d bytes, %zu given", path,
                          n + 1, size);
    }
    return BST_OK;
}

FILE *bst_output_file(const bst_output *o) { return o ? o->fp : NULL; }
const char *bst_output_temporary(const bst_output *o) { return o ? o->tmp : NULL; }
const char *bst_output_path(const bst_output *o) { return o ? o->path : NULL; }

int bst_output_flush(bst_output *o)
{
    if (!o || !o->fp)
        return BST_EINVAL;
    /* the reason of an error: the failed flush's errno, or EIO for an error an earlier write met */
    errno = 0;
    if (fflush(o->fp) == 0 && !ferror(o->fp))
        return BST_OK;
    return bsti_error(o->ctx, BST_EIO, "%s: error writing: %s", o->path, strerror(errno ? errno : EIO));
}

int bst_output_commit(bst_output *o)
{
    if (!o)
        return BST_EINVAL;
    int rc = o->fp ? bst_output_flush(o) : BST_EINVAL;
    if (o->fp) {
        int closed = fclose(o->fp) == 0;
        o->fp = NULL;
        if (rc >= 0 && !closed)
            rc = bsti_error(o->ctx, BST_EIO, "%s: error writing: %s", o->path, strerror(errno));
    }
    if (rc >= 0 && o->tmp && rename(o->tmp, o->target) != 0)
        rc = bsti_error(o->ctx, BST_EIO, "%s: cannot rename output into place: %s", o->path,
                        strerror(errno));
    if (rc >= 0) {
        bsti_free(o->ctx, o->tmp); /* in place: nothing to remove */
        o->tmp = NULL;
    }
    bst_output_abort(o);
    return rc;
}

void bst_output_abort(bst_output *o)
{
    if (!o)
        return;
    if (o->fp)
        fclose(o->fp);
    if (o->tmp)
        unlink(o->tmp);
    bst_ctx *ctx = o->ctx;
    bsti_free(ctx, o->tmp);
    bsti_free(ctx, o->target);
    bsti_free(ctx, o->path);
    bsti_free(ctx, o);
}
