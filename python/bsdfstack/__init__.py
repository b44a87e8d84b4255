"""bsdfstack - BSDFs of window systems from the BSDFs of their layers, in Python.

A thin layer over the C library libbsdfstack (through ctypes: nothing is computed here that the
library does not compute; the combination, resampling, metrics and the XML reader and writer are
the library's).  The conventions are include/bsdfstack.h's: +Z points into the room, the front
is the exterior side, layers are listed exterior first, a component is a matrix whose column is
the incident patch (the patch of the light's propagation direction) and whose row is the
outgoing patch, values are BSDF in 1/sr.

    import bsdfstack
    g = bsdfstack.glass("clear-6mm")
    b = bsdfstack.load("blind.xml")      # or a shade from its geometry, an IGSDB record:
    # b = bsdfstack.venetian(width="16mm", spacing="14.5mm", tilt=45, rs=0.765, r=0.085)
    # b = bsdfstack.shade("blind.json", tilt=30)
    s = bsdfstack.combine([g, b, g], k=6, only="Tf,Rb", precision="single")
    tf = s.matrix("Tf", "Visible")       # numpy, N x N, a view on the library's buffer
    s.hemispherical("Tf", 45, 90)        # directional-hemispherical T, light along (45, 90)
    front, back = s.absorptance()        # per layer and incident patch
    s.write("system.xml")
    r = bsdfstack.compare(s, bsdfstack.load("raytraced.xml"), incident=[(45, 90)])
    r.ga["Tf"], r.la["Tf"]               # Grobe 2017 eq. 7 (per direction) and eq. 8 (per cell)

Layers load once and enter any number of stacks: a file or a pane is put onto a stack's basis
when first combined there and that layer is kept with it for the next stack over that basis.

Where the package is found
    Installed (make install), `import bsdfstack` works with the python3 configure found.  From
    the build tree, one variable:
        PYTHONPATH=BUILDDIR/python python3 ...
    (BUILDDIR is where make ran; the package there loads BUILDDIR/.libs/libbsdfstack.so).
    $BSDFSTACK_LIBRARY, when set, names the shared library to load instead.  Glass specs use
    the catalogue directory given to glass(), else $BSDFSTACK_GLASS_DIR, else the library's own.

Threads and the GIL
    ctypes.CDLL releases the GIL during every call into the library, so other Python threads
    run while a stack combines, a file is read or written.  Every object carries its own library
    context (bst_ctx) behind a lock; objects may be shared between threads, and combinations in
    several threads over shared layers run at once.

Errors
    A library error raises bsdfstack.Error carrying the library's message (and .status, its
    code); a library warning (ill-conditioned solve, energy imbalance, data completed) is
    issued as a bsdfstack.LibraryWarning through the warnings module.  Arguments this package
    checks itself (a component or channel name, an option's value) raise Error too.
"""
import ctypes
import math
import os
import sys
import threading
import warnings

import numpy as np

from . import _lib
from ._lib import lib, text, cstr, cstr_array, COMPS, Error

__version__ = text(lib.bst_version())

__all__ = ["Error", "LibraryWarning", "BSDF", "Stack", "Glass", "Shade", "Comparison", "load",
           "glass", "venetian", "perforated", "woven", "shade", "combine", "columns", "Columns",
           "compare", "version", "library_path", "blas_kernels"]


class LibraryWarning(UserWarning):
    """A warning status of libbsdfstack (> 0) with the library's message."""


def version():
    """The version of the libbsdfstack actually loaded ("MAJOR.MINOR.PATCH")."""
    return text(lib.bst_version())


def library_path():
    """The path of the shared library loaded."""
    return _lib.PATH


def blas_kernels():
    """OpenBLAS's name of the kernels the dense work runs ('SkylakeX', 'Haswell', 'Prescott', ...),
    or None under another BLAS.  OpenBLAS picks them by the CPU's model as it loads and falls back
    to its SSE3 (Prescott) ones for a model it does not know (0.3.21 on recent AVX-512 Xeons,
    about seven times slower); OPENBLAS_CORETYPE, set before Python starts, chooses.  Importing
    the package warns once where that would help (as the program itself sets it: bsdfstack(1),
    ENVIRONMENT)."""
    return _lib.blas_kernels()


def _warn_kernels():
    better = _lib.better_kernels()
    if better:
        warnings.warn("OpenBLAS runs its %s kernels, which have no AVX2, on this CPU, which has "
                      "AVX2%s: set OPENBLAS_CORETYPE=%s before Python starts for dense work up to "
                      "seven times faster (bsdfstack(1), ENVIRONMENT)"
                      % (_lib.blas_kernels(), " and AVX-512" if better == "SkylakeX" else "",
                         better), RuntimeWarning, stacklevel=3)


_warn_kernels()


# ------------------------------------------------------------------------------------ contexts

class _Ctx:
    """A bst_ctx with a lock: one thread at a time uses it (the library's rule, one context per
    thread).  `with ctx as c:` holds the lock and gives the pointer."""

    def __init__(self):
        self.ptr = lib.bst_ctx_new()
        if not self.ptr:
            raise MemoryError("bsdfstack: cannot allocate a library context")
        self.lock = threading.RLock()
        # What the library made in this context is freed through it, so the context is freed
        # after the last of them: users counts them (_hold, _let_go), closed says this wrapper
        # is gone.  Refcounting frees holders first anyway; this keeps the order when the
        # cycle collector finalizes a context and its holders together, in any order.
        self.users, self.closed = 0, False

    def __enter__(self):
        self.lock.acquire()
        return self.ptr

    def __exit__(self, *exc):
        self.lock.release()
        return False

    def check(self, status, what=None):
        """Raise Error for status < 0, warn for > 0, with the context's message; clear it."""
        if status == 0:
            return status
        msg = text(lib.bst_ctx_message(self.ptr)) or text(lib.bst_strerror(status))
        if what:
            msg = "%s: %s" % (what, msg)
        lib.bst_ctx_clear(self.ptr)
        if status < 0:
            raise Error(msg, status)
        warnings.warn(msg, LibraryWarning, stacklevel=3)
        return status

    def release(self):
        with self.lock:
            self.users -= 1
            last = self.closed and self.users == 0
        if last:
            self._free()

    def _free(self):
        # Nothing is freed while the interpreter shuts down (module globals, lib among them, go
        # in any order then), and the process's memory goes back anyway.
        ptr, self.ptr = getattr(self, "ptr", None), None
        if ptr and lib is not None and not sys.is_finalizing():
            lib.bst_ctx_free(ptr)

    def __del__(self):
        self.closed = True
        if getattr(self, "users", 0) == 0:
            self._free()


def _hold(obj, ctx):
    """obj now owns something made in ctx: ctx stays until _let_go(obj)."""
    with ctx.lock:
        ctx.users += 1
    obj._held_ctx = ctx


def _let_go(obj):
    ctx = obj.__dict__.pop("_held_ctx", None)
    if ctx is not None:
        ctx.release()


class _Progress:
    """A progress callback installed on a context for one call.  The ctypes function object is
    kept here (and so alive) for as long as the library may call it; an exception the Python
    callback raises is held and raised once the library call has returned (the library cannot
    be interrupted)."""

    def __init__(self, ctx, fn):
        self.ctx, self.fn, self.error = ctx, fn, None
        self.cfn = _lib.PROGRESS_FN(self._call) if fn else _lib.PROGRESS_FN()

    def _call(self, fraction, label, opaque):
        if self.error is None:
            try:
                self.fn(fraction, text(label))
            except BaseException as e:  # noqa: B902 - raised again after the call
                self.error = e

    def __enter__(self):
        lib.bst_ctx_set_progress(self.ctx.ptr, self.cfn, None)
        return self

    def __exit__(self, *exc):
        lib.bst_ctx_set_progress(self.ctx.ptr, _lib.PROGRESS_FN(), None)
        if exc[0] is None and self.error is not None:
            raise self.error
        return False


def _comp_index(name):
    if isinstance(name, int) and 0 <= name < 4:
        return name
    c = lib.bst_comp_parse(cstr(str(name))) if isinstance(name, str) else -1
    if c < 0:
        raise Error("unknown component %r: use Tf, Rf, Tb or Rb" % (name,))
    return c


def _comps_mask(only):
    """A BST_COMP_BIT mask from "Tf,Rb", ["Tf", "Rb"] or None (0 = all)."""
    if only is None:
        return 0
    names = only.split(",") if isinstance(only, str) else list(only)
    mask = 0
    for n in names:
        mask |= 1 << _comp_index(n.strip() if isinstance(n, str) else n)
    return mask


def _precision(p):
    if p in ("double", "float64", np.float64, None):
        return _lib.BST_DOUBLE
    if p in ("single", "float", "float32", np.float32):
        return _lib.BST_FLOAT
    raise Error("precision %r: use \"double\" or \"single\"" % (p,))


def _direction(theta, phi):
    """The unit vector of a propagation direction (theta, phi) in degrees, nudged off cell
    boundaries onto the +x, +y side as the program's info and compare do.  As the program's
    --incident: finite, 0 <= theta < 90 (NaN gave patch 2^63 and garbage), else Error."""
    theta, phi = float(theta), float(phi)
    if not (math.isfinite(theta) and math.isfinite(phi) and 0.0 <= theta < 90.0):
        raise Error("direction (%r, %r): give theta and phi in degrees, finite, 0 <= theta < 90"
                    % (theta, phi))
    t, p = math.radians(theta), math.radians(phi)
    return (ctypes.c_double * 3)(math.sin(t) * math.cos(p) + 1e-9, math.sin(t) * math.sin(p) + 1e-9,
                                 math.cos(t))


# -------------------------------------------------------------------------------------- bases

class _Basis:
    """A bst_basis owned here (freed with this object); it holds the context whose allocator made
    it, which the library frees it through."""

    def __init__(self, ptr, ctx):
        self.ptr, self.ctx = ptr, ctx
        _hold(self, ctx)

    @classmethod
    def make(cls, ctx, k=None, klems=None):
        out = ctypes.c_void_p()
        with ctx as c:
            if klems is not None:
                ctx.check(lib.bst_basis_new_klems(c, cstr(klems), ctypes.byref(out)))
            else:
                ctx.check(lib.bst_basis_new_sc(c, int(k), ctypes.byref(out)))
        return cls(out.value, ctx)

    @classmethod
    def copy(cls, ctx, ptr):
        out = ctypes.c_void_p()
        with ctx as c:
            ctx.check(lib.bst_basis_copy(c, ptr, ctypes.byref(out)))
        return cls(out.value, ctx)

    def __del__(self):
        ptr, self.ptr = getattr(self, "ptr", None), None
        if ptr and lib is not None and not sys.is_finalizing():
            lib.bst_basis_free(ptr)
        _let_go(self)


def _basis_key(ptr):
    """What identifies a basis in a layer cache (bst_basis_equal confirms a hit)."""
    return (lib.bst_basis_kind_of(ptr), lib.bst_basis_order(ptr), lib.bst_basis_size(ptr),
            lib.bst_basis_name(ptr))


def _basis_text(ptr):
    if lib.bst_basis_kind_of(ptr) == _lib.BST_BASIS_KLEMS:
        return "%s (%d patches)" % (text(lib.bst_basis_name(ptr)), lib.bst_basis_size(ptr))
    return "Shirley-Chiu k = %d (%d patches)" % (lib.bst_basis_order(ptr), lib.bst_basis_size(ptr))


# --------------------------------------------------------------------------------- the layers

class _Buffer:
    """The dense storage of one component as numpy sees it (__array_interface__); it holds the
    BSDF that owns the storage, so an array made from it keeps that BSDF alive."""

    def __init__(self, owner, addr, rows, cols, dtype):
        self.owner = owner
        item = np.dtype(dtype).itemsize
        self.__array_interface__ = {
            "shape": (rows, cols), "typestr": np.dtype(dtype).str, "data": (addr, True),
            "strides": (item, item * rows), "version": 3}


class BSDF:
    """A BSDF over one basis: four components (Tf, Rf, Tb, Rb) per spectral channel.

    Made by load() (a file, at its own basis until combined or resampled), by combine() (a
    Stack) or by Glass.layer().  Its basis is fixed: it enters stacks over that basis."""

    def __init__(self, ptr, ctx, name=None):
        self._ptr, self._ctx = ptr, ctx
        _hold(self, ctx)
        if name is not None:
            with ctx as c:
                lib.bst_layer_set_name(c, ptr, cstr(name))

    def __del__(self):
        ptr, self._ptr = getattr(self, "_ptr", None), None
        if ptr and lib is not None and not sys.is_finalizing():
            with self._ctx:
                lib.bst_layer_free(ptr)
        _let_go(self)

    # what it is
    def _layer(self):
        return self._ptr

    @property
    def name(self):
        return text(lib.bst_layer_name(self._layer()))

    @property
    def channels(self):
        """Channel names ("Visible", "Solar", ...), in the library's order."""
        p = self._layer()
        return tuple(text(lib.bst_layer_channel(p, i)) for i in range(lib.bst_layer_nchannels(p)))

    @property
    def components(self):
        """The components present in the first channel (an absent one counts as zero when
        combined)."""
        p = self._layer()
        return tuple(n for i, n in enumerate(COMPS) if lib.bst_layer_get(p, 0, i))

    @property
    def k(self):
        """Shirley-Chiu order of the basis, 0 for a Klems basis."""
        return lib.bst_basis_order(lib.bst_layer_basis(self._layer()))

    @property
    def basis(self):
        """The basis in words ("Shirley-Chiu k = 5 (1024 patches)", "LBNL/Klems Full (145
        patches)")."""
        return _basis_text(lib.bst_layer_basis(self._layer()))

    @property
    def size(self):
        """N, the patches per hemisphere."""
        return lib.bst_basis_size(lib.bst_layer_basis(self._layer()))

    def __repr__(self):
        return "<bsdfstack.%s %s: %s, channels %s>" % (type(self).__name__, self.name or "",
                                                      self.basis, ",".join(self.channels))

    # the basis
    def lambda_(self):
        """The projected solid angle of every patch (sr), N values (a copy)."""
        b = lib.bst_layer_basis(self._layer())
        return np.ctypeslib.as_array(lib.bst_basis_lambda(b), (lib.bst_basis_size(b),)).copy()

    def patch(self, theta, phi):
        """The patch of the light propagating along (theta, phi), degrees (as `info`)."""
        b = lib.bst_layer_basis(self._layer())
        return int(lib.bst_basis_patch(b, _direction(theta, phi)))

    def directions(self):
        """(theta, phi) in degrees of every patch centre, two arrays of N (phi in [0, 360))."""
        b = lib.bst_layer_basis(self._layer())
        n = lib.bst_basis_size(b)
        d = (ctypes.c_double * 3)()
        th, ph = np.empty(n), np.empty(n)
        for j in range(n):
            lib.bst_basis_center(b, j, d)
            th[j] = math.degrees(math.acos(min(1.0, d[2])))
            ph[j] = math.degrees(math.atan2(d[1], d[0])) % 360.0
        return th, ph

    def _channel(self, channel):
        p = self._layer()
        if channel is None:
            return 0
        if isinstance(channel, int):
            if 0 <= channel < lib.bst_layer_nchannels(p):
                return channel
        else:
            ch = lib.bst_layer_find_channel(p, cstr(channel))
            if ch >= 0:
                return ch
        raise Error("no channel %r in %s (it has %s)" % (channel, self.name or "this BSDF",
                                                         ", ".join(self.channels)))

    def _component(self, comp, channel):
        ch, c = self._channel(channel), _comp_index(comp)
        m = lib.bst_layer_get(self._layer(), ch, c)
        if not m:
            raise Error("%s: component %s is absent (channel %s)" % (self.name or "BSDF", COMPS[c],
                                                                      self.channels[ch]))
        return ch, c, m

    # the values
    def matrix(self, comp, channel=None):
        """Component comp ("Tf", "Rf", "Tb", "Rb") of a channel (name or index, default the
        first) as an N x N numpy array: column j = incident patch j, row i = outgoing patch i,
        BSDF in 1/sr.

        A dense component comes back as a read-only view on the library's own column-major
        buffer (no copy; float32 or float64 as stored): the array's base holds this object, so
        the view stays valid as long as the array lives, even after every other reference to
        this object is gone.  A diagonal, sparse, factored or zero component comes back as a
        dense float64 copy (N x N).  An absent component raises Error."""
        ch, c, m = self._component(comp, channel)
        rows, cols = lib.bst_mat_rows(m), lib.bst_mat_cols(m)
        if lib.bst_mat_structure(m) == _lib.BST_DENSE:
            dtype = np.float32 if lib.bst_mat_precision(m) == _lib.BST_FLOAT else np.float64
            arr = np.asarray(_Buffer(self, lib.bst_mat_dense_data(m), rows, cols, dtype))
            arr.flags.writeable = False
            return arr
        out = np.empty((rows, cols), order="F")
        with self._ctx as cp:
            self._ctx.check(lib.bst_mat_to_dense_array(cp, m, out.ctypes.data_as(_lib.double_p)))
        return out

    def structure(self, comp, channel=None):
        """How the library stores a component: "zero", "diagonal", "sparse", "dense", "factored"
        (a coarse tree read at a finer order: its coarse matrix and the prolongation) or
        "sparse+low-rank" (a venetian blind with a mirror part and diffuse slats)."""
        m = self._component(comp, channel)[2]
        return ("zero", "diagonal", "sparse", "dense", "factored",
                "sparse+low-rank")[lib.bst_mat_structure(m)]

    def hemispherical(self, comp, theta=None, phi=None, channel=None):
        """Directional-hemispherical value of comp (T for Tf/Tb, R for Rf/Rb): sum over the
        outgoing patches of Lambda_i M(i, j).  Without theta and phi, all N incident patches
        (an array); with them, the value for the light propagating along (theta, phi), degrees
        (scalars: a float; sequences: an array)."""
        ch, c, _ = self._component(comp, channel)
        n = self.size
        out = np.empty(n)
        with self._ctx as cp:
            self._ctx.check(lib.bst_layer_hemispherical(cp, self._layer(), ch, c,
                                                        out.ctypes.data_as(_lib.double_p)))
        if theta is None and phi is None:
            return out
        if np.ndim(theta) == 0 and np.ndim(phi) == 0:
            return float(out[self.patch(theta, phi)])
        t, p = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
        return np.array([out[self.patch(a, b)] for a, b in zip(t.ravel(), p.ravel())]).reshape(t.shape)

    def flip(self):
        """The BSDF reversed (back side to the exterior), as a new BSDF."""
        ctx, out = _Ctx(), ctypes.c_void_p()
        with ctx as c:
            ctx.check(lib.bst_layer_flip(c, self._layer(), ctypes.byref(out)))
        return BSDF(out.value, ctx, (self.name or "BSDF") + "^")

    def write(self, path, reduce=90.0, rank="auto", digits=None, name=None, description=None,
              date=None, progress=None, reduce_tol=None):
        """Write as BSDF XML (a Klems matrix file over a Klems basis, else a RADIANCE tensor
        tree), as `bsdfstack combine -o` does: the file appears whole or not at all.
        reduce: the culling percentile (None or False: an exact, unreduced tree); reduce_tol:
        the largest change the reduction may make to any incident patch's directional-
        hemispherical T or R (None: the library's default, 0.002; float("inf"): the percentile
        alone); rank: "auto", 3 or 4; digits: significant digits (0: enough to read back
        exactly; None: exact, but 5 in a reduced tree, more where reduce_tol needs them; digits
        whose rounding could move a reduced tree's hemispherical T or R beyond reduce_tol raise
        Error); date: the header's date (default: $SOURCE_DATE_EPOCH when set, else now).  A
        forced rank 3, or digits where no bound holds them (reduce None, Klems), that move a
        hemispherical T or R beyond the tolerance are written with a LibraryWarning stating the
        change."""
        opts = _lib.WriteOpts()
        lib.bst_bsdf_write_opts_init(ctypes.byref(opts))
        opts.reduce_pct = -1.0 if reduce is None or reduce is False else float(reduce)
        if reduce_tol is not None:
            opts.reduce_tol = float(reduce_tol)
        if rank not in ("auto", 3, 4):
            raise Error("rank %r: use \"auto\", 3 or 4" % (rank,))
        opts.rank = 0 if rank == "auto" else rank
        if digits is not None:
            opts.digits = int(digits)
        keep = [cstr(name), cstr(description or self._description()), cstr(date or _epoch_date())]
        opts.name, opts.description, opts.date = keep
        with self._ctx as c, _Progress(self._ctx, progress):
            self._ctx.check(lib.bst_bsdf_write_path(c, self._layer(), cstr(os.fspath(path)),
                                                    ctypes.byref(opts)))

    def _description(self):
        return None


_LAST_SOURCE_DATE = 253402300799  # 9999-12-31T23:59:59Z, as the program


def _epoch_date():
    """$SOURCE_DATE_EPOCH as an ISO 8601 UTC date, as the program reads it; None when unset or
    empty.  A malformed value is an Error, as the program's (reproducible-builds.org asks it)."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "")
    if not epoch:
        return None
    if epoch.isascii() and epoch.isdigit() and int(epoch) <= _LAST_SOURCE_DATE:
        import time
        return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(int(epoch)))
    raise Error("SOURCE_DATE_EPOCH %r is not a whole number of seconds since 1970 (0 to %d): unset "
                "it or give one" % (epoch, _LAST_SOURCE_DATE))


# ------------------------------------------------------------------------- sources of layers

class _Source:
    """Something that becomes a layer over any basis: a file (load), a pane (glass) or a shade
    (venetian, perforated, woven, shade).  The layers it makes are kept, one per (basis,
    precision, channels, glass rule), for the next stack over the same basis."""

    def __init__(self):
        self._ctx = _Ctx()
        self._cache = {}

    def _on(self, basis, prec, channels, at_centre):
        """(layer pointer, owner to keep alive) over basis (a bst_basis pointer)."""
        key = (_basis_key(basis), prec, channels, at_centre and isinstance(self, Glass))
        with self._ctx:
            for (k, b), held in self._cache.items():
                if k == key and lib.bst_basis_equal(b.ptr, basis):
                    return held._ptr, held
            held = self._make(basis, prec, channels, at_centre)
            b = _Basis.copy(self._ctx, basis)
            self._cache[(key, b)] = held
            return held._ptr, held

    def forget(self):
        """Free the layers kept for stacks (they are made again when needed)."""
        with self._ctx:
            self._cache.clear()

    def flip(self):
        """This layer reversed (back side to the exterior), for a stack: combine([g, b.flip()])
        is the program's `glass:... blind.xml^`."""
        return _Flipped(self)


class _Flipped:
    """A source taken reversed."""

    def __init__(self, inner):
        self.inner = inner

    @property
    def name(self):
        return self.inner.name + "^"

    def _on(self, basis, prec, channels, at_centre):
        key = ("flip", _basis_key(basis), prec, channels, at_centre)
        ctx = self.inner._ctx
        with ctx:
            for (k, b), held in self.inner._cache.items():
                if k == key and lib.bst_basis_equal(b.ptr, basis):
                    return held._ptr, held
            ptr, owner = self.inner._on(basis, prec, channels, at_centre)
            held = owner.flip()
            lib.bst_layer_set_name(held._ctx.ptr, held._ptr, cstr(self.name))
            self.inner._cache[(key, _Basis.copy(ctx, basis))] = held
            return held._ptr, held


class File(_Source, BSDF):
    """A BSDF XML file (Klems, TensorTree3 or TensorTree4), read once (load()).  As a BSDF it is
    the file at its own basis (made on first use); in a stack it is resampled onto the stack's
    basis (bsdfstack-convert(1)); resample() gives it over another basis."""

    def __init__(self, path, channels=None, only=None, progress=None, rank3="exact"):
        _Source.__init__(self)
        if rank3 not in ("exact", "native"):
            raise ValueError("rank3=%r: use 'exact' or 'native'" % (rank3,))
        self.path = os.fspath(path)
        self._bsdf = None
        self._ptr = None
        self._own = None
        opts = _lib.ReadOpts()
        opts.comps = _comps_mask(only)
        names = [] if channels is None else [channels] if isinstance(channels, str) else list(channels)
        arr = cstr_array(names)
        opts.nchannels, opts.channels, opts.precision = len(names), arr, _lib.BST_DOUBLE
        out = ctypes.c_void_p()
        with self._ctx as c, _Progress(self._ctx, progress):
            st = lib.bst_bsdf_read(c, cstr(self.path), ctypes.byref(opts), ctypes.byref(out))
            self._bsdf = out.value
            if out.value:
                _hold(self, self._ctx)
            if st == _lib.BST_WDATA and self._only_reciprocity(opts.comps):
                lib.bst_ctx_clear(c)  # what every TensorTree4 file expects: no warning
                st = 0
            self._ctx.check(st)
            self._ctx.check(lib.bst_bsdf_set_rank3_rule(c, self._bsdf, rank3 == "native"))

    def _only_reciprocity(self, mask):
        """Whether the reader completed nothing but a transmission from the other side's (the
        program is silent about that; a component taken as zero, negative values read as 0 or
        a tree averaged to k = 7 stay warnings)."""
        b = self._bsdf
        if lib.bst_bsdf_negatives(b) or lib.bst_bsdf_depth(b) != lib.bst_bsdf_order(b):
            return False
        for ch in range(lib.bst_bsdf_nchannels(b)):
            for c in range(4):
                if mask and not mask & (1 << c) or lib.bst_bsdf_stored(b, ch, c):
                    continue
                if c not in (0, 2) or not lib.bst_bsdf_stored(b, ch, 2 - c):
                    return False
        return True

    def __del__(self):
        self._cache = {}
        self._own = None
        ptr, self._bsdf = getattr(self, "_bsdf", None), None
        if ptr and lib is not None and not sys.is_finalizing():
            lib.bst_bsdf_free(ptr)
        _let_go(self)

    @property
    def name(self):
        return self.path

    @property
    def order(self):
        """Tensor-tree order k at which the file is read, 0 for a Klems file."""
        return lib.bst_bsdf_order(self._bsdf)

    @property
    def file_kind(self):
        """"Klems", "TensorTree3" or "TensorTree4"."""
        return {0: "Klems", 3: "TensorTree3", 4: "TensorTree4"}[lib.bst_bsdf_kind(self._bsdf)]

    def stored(self, comp, channel=0):
        """Whether the file stores comp (False: derived by reciprocity, or zero)."""
        return bool(lib.bst_bsdf_stored(self._bsdf, channel, _comp_index(comp)))

    def _layer(self):
        if self._own is None:
            with self._ctx as c:
                own = ctypes.c_void_p()
                self._ctx.check(lib.bst_bsdf_to_layer(c, self._bsdf, None, ctypes.byref(own)))
                self._own = BSDF(own.value, self._ctx, self.path)
        return self._own._ptr

    def resample(self, k=None, klems=None, precision="double"):
        """The file over Shirley-Chiu order k or a Klems basis (klems = "full", "half",
        "quarter"), as a new BSDF."""
        basis = _Basis.make(self._ctx, k, klems)
        ptr, owner = self._on(basis.ptr, _precision(precision), None, False)
        return owner

    def _make(self, basis, prec, channels, at_centre):
        out = ctypes.c_void_p()
        c = self._ctx.ptr
        self._ctx.check(lib.bst_bsdf_to_layer(c, self._bsdf, basis, ctypes.byref(out)))
        held = BSDF(out.value, self._ctx, self.path)
        names = [text(lib.bst_bsdf_channel(self._bsdf, i)) for i in range(lib.bst_bsdf_nchannels(self._bsdf))]
        keep = names if channels is None else [n for n in names if n.lower() in
                                               [x.lower() for x in channels]]
        if not keep:  # the reader's own message for a channel the file lacks
            opts = _lib.ReadOpts()
            arr = cstr_array(channels)
            opts.nchannels, opts.channels = len(channels), arr
            tmp = ctypes.c_void_p()
            st = lib.bst_bsdf_read(c, cstr(self.path), ctypes.byref(opts), ctypes.byref(tmp))
            lib.bst_bsdf_free(tmp.value)
            self._ctx.check(st)
            raise Error("%s: no channel %s" % (self.path, ", ".join(channels)))
        if keep != names or prec != _lib.BST_DOUBLE:
            held = _copy_layer(self._ctx, held, keep, prec)
        return held


def _copy_layer(ctx, src, names, prec):
    """A copy of the channels `names` of src, dense components in precision prec (a file read
    once in double serves stacks in single precision and with fewer channels)."""
    out = ctypes.c_void_p()
    c = ctx.ptr
    arr = cstr_array(names)
    ctx.check(lib.bst_layer_new(c, lib.bst_layer_basis(src._ptr), len(names), arr, ctypes.byref(out)))
    dst = BSDF(out.value, ctx, src.name)
    for i, n in enumerate(names):
        ch = lib.bst_layer_find_channel(src._ptr, cstr(n))
        for comp in range(4):
            m = lib.bst_layer_get(src._ptr, ch, comp)
            if not m:
                continue
            s = lib.bst_mat_structure(m)
            p = prec if s == _lib.BST_DENSE else lib.bst_mat_precision(m)
            cp = ctypes.c_void_p()
            ctx.check(lib.bst_mat_convert(c, m, s, p, ctypes.byref(cp)))
            ctx.check(lib.bst_layer_set(c, dst._ptr, i, comp, cp.value))
    return dst


class Glass(_Source):
    """A pane from a glass spec (bsdfstack-glass(5)): a catalogue name ("clear-6mm",
    "nfrc-102"), a spectral data file (bsdfstack's table, an Optics file, an IGSDB record), or an
    inline pane ("d=6mm,n=1.52,tn=0.89"); ",model=coated" or ",model=uncoated" after any of them
    chooses the angular model.  channels: the bands that spectral data without bands of their own
    are averaged over (default Visible and Solar), e.g. ["Visible"] for data that cover only the
    visible (bst_glass_parse_bands)."""

    def __init__(self, spec, catalogue=None, channels=None):
        _Source.__init__(self)
        if spec.startswith("glass:"):
            spec = spec[6:]
        self.spec = spec
        self.catalogue = catalogue if catalogue is not None else os.environ.get("BSDFSTACK_GLASS_DIR")
        self.bands = None if channels is None else [str(x) for x in channels]
        self._g = self._parse()

    def _parse(self):
        out = ctypes.c_void_p()
        with self._ctx as c:
            if self.bands:
                names = (ctypes.c_char_p * len(self.bands))(*[cstr(x) for x in self.bands])
                st = lib.bst_glass_parse_bands(c, cstr(self.spec), cstr(self.catalogue),
                                               len(self.bands), names, ctypes.byref(out))
            else:
                st = lib.bst_glass_parse(c, cstr(self.spec), cstr(self.catalogue), ctypes.byref(out))
            if st < 0 and out.value:
                lib.bst_glass_free(out.value)
            self._ctx.check(st)
        return _GlassPtr(out.value, self._ctx)

    @property
    def name(self):
        return "glass:" + self.spec

    @property
    def channels(self):
        g = self._g.ptr
        return tuple(text(lib.bst_glass_channel(g, i)) for i in range(lib.bst_glass_nchannels(g)))

    @property
    def description(self):
        return text(lib.bst_glass_description(self._g.ptr))

    @property
    def spectral(self):
        """Whether the pane has spectral data (a stack of such panes combines per wavelength)."""
        return lib.bst_glass_nwavelengths(self._g.ptr) > 0

    @property
    def model(self):
        """The angular model: "uncoated" (the slab) or "coated" (WINDOW's correlations)."""
        return text(lib.bst_glass_model_name(lib.bst_glass_get_model(self._g.ptr)))

    @property
    def source(self):
        """Where the pane comes from: "catalogue", "table" (bsdfstack's spectral table),
        "optics" (an Optics / IGDB text file), "igsdb" (an IGSDB JSON record) or "inline"."""
        return text(lib.bst_glass_metadata(self._g.ptr).contents.source)

    @property
    def metadata(self):
        """What the pane's source says of it, as bsdfstack-glass(5) lists it: a dict of the
        fields given (source, path, type, model_from, product_name, manufacturer, coating_name,
        coated_side, wavelength_units: str; nfrc_id: int; thickness_mm, conductivity,
        emissivity_front, emissivity_back, ir_transmittance: float).  Fields the source does
        not give are left out; source and model_from are always there."""
        m = lib.bst_glass_metadata(self._g.ptr).contents
        out = {}
        for name, kind in _lib.GlassMeta._fields_:
            v = getattr(m, name)
            if kind is ctypes.c_char_p:
                v = text(v)
                if v or name in ("source", "model_from"):
                    out[name] = v
            elif name == "nfrc_id":
                if v >= 0:
                    out[name] = int(v)
            elif v == v:  # NaN: not given
                out[name] = float(v)
        return out

    def __repr__(self):
        return "<bsdfstack.Glass %s: %s>" % (self.spec, self.description)

    def layer(self, k=None, klems=None, channels=None, glass_rule="average"):
        """The pane over Shirley-Chiu order k (default 5) or a Klems basis, as a BSDF (four
        diagonal components)."""
        basis = _Basis.make(self._ctx, 5 if k is None and klems is None else k, klems)
        return self._on(basis.ptr, _lib.BST_DOUBLE, _names(channels), _glass_rule(glass_rule))[1]

    def _pane_for(self, channels):
        """The parsed pane, or a fresh one with the requested bands it lacks added (a spectral
        pane is averaged over any band asked for, as the program does)."""
        g = self._g.ptr
        extra = [n for n in channels or () if lib.bst_glass_find_channel(g, cstr(n)) < 0 and
                 lib.bst_glass_nwavelengths(g) and lib.bst_plan_is_band(cstr(n))]
        if not extra:
            return self._g
        fresh = self._parse()
        for n in extra:
            self._ctx.check(lib.bst_glass_add_channel(self._ctx.ptr, fresh.ptr, cstr(n)))
        return fresh

    def _warn_groups(self, pane, channels):
        """A LibraryWarning, as the program's line, when a channel of many wavelengths is summed
        in groups of adjacent ones (bst_glass_layer_nodes; ",rows=all" in the spec sums each)."""
        g = pane.ptr
        for i in range(lib.bst_glass_nchannels(g)):
            name = text(lib.bst_glass_channel(g, i))
            if channels and name not in channels:
                continue
            rows = ctypes.c_size_t()
            nodes = lib.bst_glass_layer_nodes(g, i, ctypes.byref(rows))
            if nodes < rows.value:
                warnings.warn("%s: its layer sums the model over %d groups of adjacent wavelengths "
                              "(each at their weighted mean data) instead of %s's %d wavelengths "
                              "one by one; rows=all after the file name takes each"
                              % (self.name, nodes, name, rows.value), LibraryWarning, stacklevel=4)

    def _make(self, basis, prec, channels, at_centre):
        pane = self._pane_for(channels)
        self._warn_groups(pane, channels)
        out = ctypes.c_void_p()
        names = cstr_array(channels or ())
        self._ctx.check(lib.bst_glass_layer(self._ctx.ptr, pane.ptr, basis,
                                            len(channels or ()), names if channels else None,
                                            int(at_centre), ctypes.byref(out)), self.name)
        held = BSDF(out.value, self._ctx, self.name)
        held._pane = pane  # the per-wavelength path combines the pane itself
        return held


class _GlassPtr:
    """A parsed pane owned here, with the context whose allocator made it."""

    def __init__(self, ptr, ctx):
        self.ptr, self.ctx = ptr, ctx
        _hold(self, ctx)

    def __del__(self):
        ptr, self.ptr = getattr(self, "ptr", None), None
        if ptr and lib is not None and not sys.is_finalizing():
            lib.bst_glass_free(ptr)
        _let_go(self)


class Shade(_Source):
    """A shade made from its geometry (bsdfstack-glass(5)): a venetian blind, a perforated screen
    or a woven fabric, from a spec ("venetian:width=16mm,...") or an IGSDB shading record
    ("shade:FILE.json,tilt=30"); made over any stack's basis (default Shirley-Chiu k = 5), with
    channels Visible and Solar.  venetian(), perforated(), woven() and shade() make them."""

    def __init__(self, spec, catalogue=None):
        _Source.__init__(self)
        self.spec = os.fspath(spec)
        self.catalogue = catalogue if catalogue is not None else os.environ.get("BSDFSTACK_GLASS_DIR")
        self.model = self._model(self.spec)

    def _model(self, spec):
        buf = ctypes.create_string_buffer(2048)
        with self._ctx as c:
            self._ctx.check(lib.bst_shade_spec_model(c, cstr(spec), cstr(self.catalogue), buf,
                                                     len(buf)))
        return text(buf.value)

    @property
    def name(self):
        return self.spec

    @property
    def kind(self):
        """"venetian", "perforated" or "woven": the model the layer is made from."""
        return self.model.split(":", 1)[0]

    def __repr__(self):
        return "<bsdfstack.Shade %s: %s>" % (self.spec, self.model)

    def layer(self, k=None, klems=None, channels=None):
        """The shade over Shirley-Chiu order k (default 5) or a Klems basis, as a BSDF."""
        basis = _Basis.make(self._ctx, 5 if k is None and klems is None else k, klems)
        return self._on(basis.ptr, _lib.BST_DOUBLE, _names(channels), False)[1]

    def _make(self, basis, prec, channels, at_centre):
        out = ctypes.c_void_p()
        names = cstr_array(channels or ())
        self._ctx.check(lib.bst_shade_spec_layer(self._ctx.ptr, cstr(self.spec), cstr(self.catalogue),
                                                 basis, len(channels or ()),
                                                 names if channels else None, ctypes.byref(out)),
                        self.name)
        held = BSDF(out.value, self._ctx, self.name)
        if prec != _lib.BST_DOUBLE:  # dense work in single precision, as a file's
            held = _copy_layer(self._ctx, held, list(held.channels), prec)
        return held


# spec keys that are lengths, per model: a number given for one of them is metres
_LENGTH_KEYS = {"venetian": ("width", "spacing", "curvature"),
                "perforated": ("x", "y", "thickness", "radius", "hole-x", "hole-y"),
                "woven": ("diameter", "spacing")}


def _spec_items(kind, keys):
    """key=value items of a shade spec from keyword arguments: names with _ for - (r_up is
    r-up), a number for a length in metres (strings with units as the spec takes them: "16mm"),
    a pair (visible, solar) as VISIBLE/SOLAR, True for a flag, None or False left out."""
    items = []
    for name, v in keys.items():
        key = name.replace("_", "-")
        if v is None or v is False:
            continue
        if v is True:
            items.append(key)
            continue
        if isinstance(v, (tuple, list)):
            if len(v) != 2:
                raise Error("%s: give one value or a (visible, solar) pair, not %r" % (key, v))
            items.append("%s=%s/%s" % (key, _spec_value(kind, key, v[0]), _spec_value(kind, key, v[1])))
        else:
            items.append("%s=%s" % (key, _spec_value(kind, key, v)))
    return ",".join(items)


def _spec_value(kind, key, v):
    if isinstance(v, str):
        return v
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise Error("%s: %r is not a number or a string" % (key, v))
    x = float(v)
    if key in _LENGTH_KEYS.get(kind, ()):
        return repr(x) + "m"
    return repr(int(v)) if isinstance(v, int) else repr(x)


def venetian(catalogue=None, **keys):
    """A venetian blind from its geometry: venetian(width=0.016, spacing=0.0145, tilt=45,
    rs=0.765, r=0.085, roughness=0.02), the keys of the venetian: spec (bsdfstack-glass(5);
    r_up, r_down for r-up, r-down), lengths in metres or as strings with units ("16mm"),
    (visible, solar) pairs for dual-band slats, vertical=True."""
    return Shade("venetian:" + _spec_items("venetian", keys), catalogue)


def perforated(catalogue=None, **keys):
    """A perforated screen: perforated(x=0.005, y=0.005, radius=0.0015, thickness=0.001, r=0.7),
    or hole_x, hole_y for rectangular holes; rf, rb, t, samples; rule="centre" for WINDOW's
    model (bsdfstack-glass(5)); as venetian() takes them."""
    return Shade("perforated:" + _spec_items("perforated", keys), catalogue)


def woven(catalogue=None, **keys):
    """A woven fabric: woven(diameter=0.0005, spacing=0.002, r=0.6, t=0.1) (or rf, rb;
    rule="centre" for WINDOW's model)."""
    return Shade("woven:" + _spec_items("woven", keys), catalogue)


def shade(path, catalogue=None, **overrides):
    """An IGSDB shading record (a v1 JSON record of a venetian, perforated-screen or woven
    product) as the layer of its geometric model: shade("blind.json", tilt=30, segments=8);
    the keyword arguments are that model's keys (as venetian() etc. take them) and replace the
    record's values.  .model is the equivalent spec."""
    path = os.fspath(path)
    if not overrides:
        return Shade("shade:" + path, catalogue)
    kind = Shade("shade:" + path, catalogue).kind
    return Shade("shade:%s,%s" % (path, _spec_items(kind, overrides)), catalogue)


def load(path, channels=None, only=None, progress=None, rank3="exact"):
    """Read a BSDF XML file once (Klems, TensorTree3, TensorTree4, any resolution).
    channels: names to read (default all); only: components to read ("Tf,Rb"; default all; the
    reader completes a missing transmission by reciprocity, with a LibraryWarning for anything
    it takes as zero); rank3: how a TensorTree3 of depth d meets a finer order in a stack,
    "exact" (sampled at that order) or "native" (at order d, held factored: faster, coarser;
    combine --rank3 in bsdfstack-combine(1))."""
    return File(path, channels, only, progress, rank3)


def glass(spec, catalogue=None, channels=None):
    """A pane: glass("clear-6mm"), glass("nfrc-102"), glass("d=6mm,n=1.52,tn=0.89"),
    glass("CLEAR_6.DAT"), glass("lowe-6mm,model=uncoated").
    catalogue: the directory of .glass files (default $BSDFSTACK_GLASS_DIR, else the
    library's); channels: the bands spectral data without bands of their own are averaged over
    (glass("vis.tsv", channels=["Visible"]) for data that cover only the visible)."""
    return Glass(spec, catalogue, channels)


def _as_layer(x):
    """A stack entry: a BSDF, File, Glass, Shade, a flipped source, or a program-style string
    ("glass:clear-6mm", "venetian:...", "shade:rec.json", "blind.xml", a trailing ^ for
    reversed)."""
    if isinstance(x, (_Source, _Flipped, BSDF)):
        return x
    if isinstance(x, (str, os.PathLike)):
        s = os.fspath(x)
        flip = s.endswith("^")
        s = s[:-1] if flip else s
        src = (Glass(s) if s.startswith("glass:") else
               Shade(s) if s.startswith(("venetian:", "perforated:", "woven:", "shade:")) else File(s))
        return src.flip() if flip else src
    raise Error("not a layer: %r (give a BSDF, glass(...), venetian(...), load(...) or a file "
                "name)" % (x,))


def _names(channels):
    if channels is None:
        return None
    names = channels.split(",") if isinstance(channels, str) else list(channels)
    return tuple(n.strip() for n in names)


def _glass_rule(rule):
    if rule not in ("average", "centre", "center"):
        raise Error("glass_rule %r: use \"average\" or \"centre\"" % (rule,))
    return rule != "average"


def _source_of(x):
    return x.inner if isinstance(x, _Flipped) else x


# ------------------------------------------------------------------------------------ stacks

class Stack(BSDF):
    """A combined system (combine()): a BSDF that also remembers its layers, for absorptance()."""

    def __init__(self, ptr, ctx, entries, held, spectral, panes, plan, opts, sopts, basis):
        BSDF.__init__(self, ptr, ctx)
        self.layers = tuple(e.name or "BSDF" for e in entries)
        self.spectral = spectral
        self.plan = plan
        self._held, self._panes = held, panes
        self._opts, self._sopts, self._basis = opts, sopts, basis
        self._abs = None
        lib.bst_layer_set_name(ctx.ptr, ptr, cstr(" | ".join(self.layers)))

    def _description(self):
        return "layers (exterior first): %s\nspectral: %s\nmade by the bsdfstack Python package" % (
            ", ".join(self.layers), self.plan)

    def absorptance(self, channel=None):
        """Per-layer absorptance (Klems 1994, part 2) of a channel (default the first): two
        arrays (front, back), each nlayers x N: [i, j] is the share of unit flux arriving from
        incident patch j on the front (back) side that layer i absorbs.  T + R + the sum over
        layers = 1.  A stack combined per wavelength is combined once more to get them."""
        ch = self._channel(channel)
        if self._abs is None:
            self._abs = self._absorptance_all()
        return self._abs[0][ch].copy(), self._abs[1][ch].copy()

    def _absorptance_all(self):
        n, N, nch = len(self._held), self.size, len(self.channels)
        front, back = np.zeros((nch, n, N)), np.zeros((nch, n, N))
        ptrs = (ctypes.c_void_p * n)(*[h._ptr for h in self._held])
        dp = _lib.double_p
        with self._ctx as c:
            if self.spectral:
                sl = self._spectral_layers()
                names = cstr_array(self.channels)
                out = ctypes.c_void_p()
                st = lib.bst_stack_combine_spectral_layers(
                    c, n, sl, self._basis.ptr, nch, names, ctypes.byref(self._sopts),
                    ctypes.byref(self._opts), ctypes.byref(out), front.ctypes.data_as(dp),
                    back.ctypes.data_as(dp))
                lib.bst_layer_free(out.value)
                self._ctx.check(st, "absorptance")
            else:
                for k, name in enumerate(self.channels):
                    c0 = lib.bst_layer_find_channel(self._held[0]._ptr, cstr(name))
                    self._ctx.check(lib.bst_stack_absorptance(
                        c, n, ptrs, c0, ctypes.byref(self._opts), front[k].ctypes.data_as(dp),
                        back[k].ctypes.data_as(dp)), "absorptance")
        return front, back

    def _spectral_layers(self):
        return _spectral_array(self._panes, [h._ptr for h in self._held])


def _default_basis(ctx, sources):
    """The library's basis rule (bst_plan_pick_basis, as the program's): the finest tensor-tree
    order among the files, else the first Klems file's basis, else the basis of a BSDF given over
    one, else k = 5."""
    n = len(sources)
    files = (ctypes.c_void_p * max(n, 1))()
    given = (ctypes.c_void_p * max(n, 1))()
    for i, src in enumerate(sources):
        if isinstance(src, File):
            files[i] = src._bsdf
        elif isinstance(src, BSDF) and not isinstance(src, _Source):
            given[i] = lib.bst_layer_basis(src._ptr)
    pick = _lib.PlanBasis()
    lib.bst_plan_pick_basis(n, files, given, 0, None, ctypes.byref(pick))
    out = ctypes.c_void_p()
    with ctx as c:
        ctx.check(lib.bst_plan_make_basis(c, ctypes.byref(pick), n, files, given, ctypes.byref(out)))
    return _Basis(out.value, ctx)


def _on_basis(entry, basis, prec, channels, at_centre):
    """(layer pointer, owner) of a stack entry over basis."""
    if isinstance(entry, (_Source, _Flipped)):
        return entry._on(basis, prec, channels, at_centre)
    if not lib.bst_basis_equal(lib.bst_layer_basis(entry._ptr), basis):
        raise Error("%s is over %s, the stack over %s: a combined BSDF keeps its basis (the "
                    "library resamples files only: combine at the same k)" % (
                        entry.name or "BSDF", entry.basis, _basis_text(basis)))
    return entry._ptr, entry


def _common_channels(ptrs):
    """The channels every layer holds, in the first's order (bst_plan_channels)."""
    arr = (ctypes.c_void_p * len(ptrs))(*ptrs)
    names = (ctypes.c_char_p * (lib.bst_layer_nchannels(ptrs[0]) + 1))()
    m = lib.bst_plan_channels(len(ptrs), arr, names)
    return [text(names[i]) for i in range(m)]


def _spectral_plan(ctx, entries, ptrs, held, per_channel):
    """Whether the stack combines wavelength by wavelength, the panes it does so with, and why:
    the library's plan (bst_plan_spectral), as the program's; a reason a user would not expect
    (a layer with Solar but not Visible) is a LibraryWarning."""
    panes = []
    for e, h in zip(entries, held):
        pane = getattr(h, "_pane", None)
        spectral = (isinstance(e, Glass) and pane is not None and
                    lib.bst_glass_nwavelengths(pane.ptr) > 0)
        panes.append(pane if spectral else None)
    pl = (_lib.PlanLayer * len(ptrs))()
    for i, (e, p) in enumerate(zip(entries, ptrs)):
        pl[i].layer = p
        pl[i].pane = panes[i].ptr if panes[i] is not None else None
        pl[i].from_file = int(not isinstance(_source_of(e), Glass))
    why = ctypes.create_string_buffer(2048)
    spectral, warn = ctypes.c_int(0), ctypes.c_int(0)
    with ctx as c:
        ctx.check(lib.bst_plan_spectral(c, len(ptrs), pl, int(bool(per_channel)), why, len(why),
                                        ctypes.byref(spectral), ctypes.byref(warn)))
    plan = text(why.value)
    if warn.value:
        warnings.warn(plan, LibraryWarning, stacklevel=4)
    return bool(spectral.value), panes, plan


class _Prepared:
    """A stack's entries over one basis, as combine() and columns() take them: the context, the
    basis, each entry's layer pointer and owner, and the spectral plan (the program's)."""

    def __init__(self, layers, k, klems, channels, precision, glass_rule, per_channel, what):
        self.entries = [_as_layer(x) for x in layers]
        if not self.entries:
            raise Error("%s: no layers given" % what)
        self.names = _names(channels)
        self.prec = _precision(precision)
        self.at_centre = _glass_rule(glass_rule)
        self.ctx = _Ctx()
        if k is not None and klems is not None:
            raise Error("k and klems exclude each other")
        self.basis = (_Basis.make(self.ctx, k, klems) if k is not None or klems is not None else
                      _default_basis(self.ctx, [_source_of(e) for e in self.entries]))
        self.ptrs, self.held = [], []
        for e in self.entries:
            p, h = _on_basis(e, self.basis.ptr, self.prec, self.names, self.at_centre)
            self.ptrs.append(p)
            self.held.append(h)
        self.spectral, self.panes, self.plan = _spectral_plan(self.ctx, self.entries, self.ptrs,
                                                              self.held, per_channel)

    def spectral_layers(self):
        return _spectral_array(self.panes, self.ptrs)

    def spectral_opts(self, spectral_tol):
        sopts = _lib.SpectralOpts()
        lib.bst_spectral_opts_init(ctypes.byref(sopts))
        sopts.at_centre = int(self.at_centre)
        if spectral_tol is not None:
            sopts.tol = float(spectral_tol)
        return sopts


def _spectral_array(panes, ptrs):
    """The bst_spectral_layer array of a stack: its spectral panes, and its other layers as
    dual-band ones."""
    sl = (_lib.SpectralLayer * len(ptrs))()
    for i, (pane, ptr) in enumerate(zip(panes, ptrs)):
        if pane is not None:
            sl[i].pane = pane.ptr
        else:
            sl[i].bands = ptr
    return sl


def combine(layers, k=None, klems=None, only=None, precision="double", channels=None,
            drop_tol=0.0, strict=False, dense=False, per_channel=False, spectral_tol=None,
            glass_rule="average", absorptance=False, progress=None):
    """Combine layers listed exterior first into a system (a Stack), as `bsdfstack combine`.

    layers: BSDFs, load()ed files, glass() panes, x.flip() for a reversed layer, or program-style
      strings ("glass:clear-6mm", "blind.xml^").
    k / klems: the basis, Shirley-Chiu order 1..7 or "full" / "half" / "quarter" (default: the
      finest tree order among the files, else a Klems file's basis, else k = 5).
    only: the components to compute ("Tf,Rb"); precision: "double" or "single" (dense work and
      the dense layers read from files); channels: the channels to combine (default those every
      layer has); drop_tol, strict, dense: bst_stack_opts (see bsdfstack-combine(1));
      per_channel: combine band values even where the stack could go wavelength by wavelength;
      spectral_tol, glass_rule ("average" or "centre"): as the program's options.
    absorptance: compute per-layer absorptance now (else on Stack.absorptance()).
    progress: fn(fraction, label), called from the combining thread with the GIL held.
    The GIL is released while the library combines."""
    st = _Prepared(layers, k, klems, channels, precision, glass_rule, per_channel, "combine")
    ctx, basis, ptrs = st.ctx, st.basis, st.ptrs
    opts = _lib.StackOpts()
    lib.bst_stack_opts_init(ctypes.byref(opts))
    opts.comps = _comps_mask(only) or opts.comps
    opts.drop_tol, opts.strict, opts.force_dense = float(drop_tol), int(strict), int(dense)
    opts.precision = st.prec
    sopts = st.spectral_opts(spectral_tol)
    n = len(ptrs)
    out = ctypes.c_void_p()
    arr = (ctypes.c_void_p * n)(*ptrs)
    N = lib.bst_basis_size(basis.ptr)
    abs_buf = None
    with ctx as c, _Progress(ctx, progress):
        if st.spectral:
            common = _common_channels(ptrs)
            if absorptance:
                abs_buf = (np.zeros((len(common), n, N)), np.zeros((len(common), n, N)))
            dp = [None, None] if abs_buf is None else [a.ctypes.data_as(_lib.double_p) for a in abs_buf]
            rc = lib.bst_stack_combine_spectral_layers(
                c, n, st.spectral_layers(), basis.ptr, len(common), cstr_array(common),
                ctypes.byref(sopts), ctypes.byref(opts), ctypes.byref(out), dp[0], dp[1])
        else:
            rc = lib.bst_stack_combine(c, n, arr, ctypes.byref(opts), ctypes.byref(out))
        if rc < 0 and out.value:
            lib.bst_layer_free(out.value)
        ctx.check(rc, "combining per wavelength" if st.spectral else "combining")
    s = Stack(out.value, ctx, st.entries, st.held, st.spectral, st.panes, st.plan, opts, sopts, basis)
    if abs_buf is not None:
        s._abs = abs_buf
    elif absorptance:
        s._abs = s._absorptance_all()
    return s


class Columns:
    """What columns() computed.  t[channel] and r[channel]: N x m arrays, BSDF in 1/sr, of the
    system's Tf and Rf (Tb and Rb when back) for light incident along incident[q] (column q),
    exit patch i in row i (in the basis of directions() of a BSDF over it); patches: the incident
    patch of each direction; channels; iterations and residual: the most sweeps any iteration
    made and the largest last change of flux over the incident flux; spectral and plan: whether
    the stack went wavelength by wavelength, and why (as combine())."""

    def __repr__(self):
        return "<bsdfstack.Columns %d direction(s) x %d patches, %s: %d sweeps>" % (
            len(self.patches), self.size, ", ".join(self.channels), self.iterations)


def columns(layers, incident, k=None, klems=None, back=False, channels=None, precision="double",
            per_channel=False, spectral_tol=None, glass_rule="average", tol=None, max_iter=None):
    """The system's scattering for a few incident directions only, as `bsdfstack combine
    --incident`: each column iterated between the layers (never forming the whole system), in
    O(N^2) per direction and sweep.  incident: (theta, phi) pairs in degrees, the direction the
    light propagates in; back: light arriving from the back (interior) side.  The other arguments
    as combine(); tol and max_iter: the iteration's (bst_columns_opts, defaults
    BST_COLUMNS_TOL and BST_COLUMNS_MAX_ITER).  A stack that combine() would take wavelength by
    wavelength is iterated so too (its columns equal that system's).  Returns a Columns; a
    column that did not converge warns (LibraryWarning).  The GIL is released meanwhile."""
    dirs = [(float(t), float(p)) for t, p in incident]
    if not dirs:
        raise Error("columns: no incident directions given")
    st = _Prepared(layers, k, klems, channels, precision, glass_rule, per_channel, "columns")
    ctx, basis, ptrs = st.ctx, st.basis, st.ptrs
    N, n, m = lib.bst_basis_size(basis.ptr), len(ptrs), len(dirs)
    cols = (ctypes.c_size_t * m)(*[lib.bst_basis_patch(basis.ptr, _direction(t, p)) for t, p in dirs])
    copts = _lib.ColumnsOpts()
    lib.bst_columns_opts_init(ctypes.byref(copts))
    copts.back = int(bool(back))
    if tol is not None:
        copts.tol = float(tol)
    if max_iter is not None:
        copts.max_iter = int(max_iter)
    sopts = st.spectral_opts(spectral_tol)
    arr = (ctypes.c_void_p * n)(*ptrs)
    res = Columns()
    res.incident, res.patches, res.size = tuple(dirs), tuple(cols), N
    res.channels = tuple(_common_channels(ptrs))
    res.spectral, res.plan, res.t, res.r = st.spectral, st.plan, {}, {}
    res.iterations, res.residual = 0, 0.0
    with ctx as c:
        for name in res.channels:
            tm, rm = ctypes.c_void_p(), ctypes.c_void_p()
            if st.spectral:
                rc = lib.bst_stack_columns_spectral_layers(
                    c, n, st.spectral_layers(), basis.ptr, cstr(name), ctypes.byref(sopts), m, cols,
                    ctypes.byref(copts), ctypes.byref(tm), ctypes.byref(rm))
            else:
                rc = lib.bst_stack_columns(c, n, arr, cstr(name), m, cols, ctypes.byref(copts),
                                           ctypes.byref(tm), ctypes.byref(rm))
            try:
                if rc >= 0:
                    for mat, into in ((tm, res.t), (rm, res.r)):
                        a = np.empty((N, m), order="F")
                        ctx.check(lib.bst_mat_to_dense_array(c, mat.value, a.ctypes.data_as(_lib.double_p)))
                        into[name] = a
            finally:
                lib.bst_mat_free(tm.value)
                lib.bst_mat_free(rm.value)
            res.iterations = max(res.iterations, copts.iterations)
            res.residual = max(res.residual, copts.residual)
            ctx.check(rc, "%s columns%s" % (name, " per wavelength" if st.spectral else ""))
    return res


# ---------------------------------------------------------------------------------- accordance

class Comparison:
    """What compare() found, per component name ("Tf", ...):
      ga[c], fa[c]   GA (eq. 7) and FA (%) at each incident direction asked (arrays)
      la[c]          LA (eq. 8, %) of every exit cell: len(incident) x N
      hem_a[c], hem_b[c]  the directional-hemispherical values of A and B there
      ga_all[c], fa_all[c]  GA and FA of every incident patch (N values)
    and incident (the directions), patches (their incident patches), basis, channel, k."""

    def __repr__(self):
        rows = ["%s GA %s" % (c, np.array2string(self.ga[c], precision=3)) for c in self.components]
        return "<bsdfstack.Comparison %s, %s: %s>" % (self.basis, self.channel, "; ".join(rows))


def _one_channel(ctx, entry_ptr, owner, name):
    """A layer holding only channel `name` of entry (for accordance, which takes one channel
    index for both layers)."""
    ch = lib.bst_layer_find_channel(entry_ptr, cstr(name))
    if ch == 0:
        return entry_ptr, owner
    src = owner if isinstance(owner, BSDF) else None
    with ctx:
        copy = _copy_layer(ctx, src, [name], _lib.BST_DOUBLE)
    return copy._ptr, copy


def compare(a, b, incident=((0, 0), (25, 90), (45, 90), (50, 90), (45, 45), (65, 90)), k=None,
            klems=None, channel=None, only=None):
    """How far two BSDFs agree (`bsdfstack compare`): for each component, the global accordance
    GA (Grobe 2017 eq. 7), the local accordance LA of every exit cell (eq. 8) and the flux
    accordance FA, at each incident direction (theta, phi) in degrees (light propagation), and
    GA and FA of every incident patch; all as bst_metrics_accordance computes them.

    Both are put onto one basis: k or klems if given, else the program's default (the finer
    tree order of two files, a Klems file's basis).  Files and panes are resampled by the
    library as `compare -k` does; a combined BSDF keeps its basis (the C API resamples files
    only), so give k equal to its own or leave k out.  channel: default A's first (B must
    hold it); only: components (default every one either holds)."""
    ea, eb = _as_layer(a), _as_layer(b)
    ctx = _Ctx()
    if k is not None and klems is not None:
        raise Error("k and klems exclude each other")
    basis = (_Basis.make(ctx, k, klems) if k is not None or klems is not None else
             _default_basis(ctx, [_source_of(ea), _source_of(eb)]))
    pa, ha = _on_basis(ea, basis.ptr, _lib.BST_DOUBLE, None, False)
    pb, hb = _on_basis(eb, basis.ptr, _lib.BST_DOUBLE, None, False)
    name = channel if channel is not None else text(lib.bst_layer_channel(pa, 0))
    for p, e in ((pa, ea), (pb, eb)):
        if lib.bst_layer_find_channel(p, cstr(name)) < 0:
            raise Error("%s has no channel '%s'%s" % (e.name, name, "" if channel else
                        " (the first of %s): name one both hold with channel=" % ea.name))
    pa, ha = _one_channel(ctx, pa, ha, name)
    pb, hb = _one_channel(ctx, pb, hb, name)
    mask = _comps_mask(only)
    N = lib.bst_basis_size(basis.ptr)
    dirs = [tuple(map(float, d)) for d in incident]
    patches = [int(lib.bst_basis_patch(basis.ptr, _direction(t, p))) for t, p in dirs]
    r = Comparison()
    r.incident, r.patches, r.channel = dirs, patches, name
    r.basis, r.k = _basis_text(basis.ptr), lib.bst_basis_order(basis.ptr)
    r.ga, r.fa, r.la, r.hem_a, r.hem_b, r.ga_all, r.fa_all = {}, {}, {}, {}, {}, {}, {}
    comps = []
    dp = _lib.double_p
    with ctx as c:
        for ci, cname in enumerate(COMPS):
            present = bool(lib.bst_layer_get(pa, 0, ci)) or bool(lib.bst_layer_get(pb, 0, ci))
            if not (mask & (1 << ci) if mask else present):
                continue
            ga_all, fa_all, h1, h2 = np.empty(N), np.empty(N), np.empty(N), np.empty(N)
            ctx.check(lib.bst_metrics_accordance_all(c, pa, pb, 0, ci, ga_all.ctypes.data_as(dp),
                                                     fa_all.ctypes.data_as(dp)))
            ctx.check(lib.bst_layer_hemispherical(c, pa, 0, ci, h1.ctypes.data_as(dp)))
            ctx.check(lib.bst_layer_hemispherical(c, pb, 0, ci, h2.ctypes.data_as(dp)))
            ga, fa, la = np.empty(len(dirs)), np.empty(len(dirs)), np.empty((len(dirs), N))
            for q, j in enumerate(patches):
                g, f = ctypes.c_double(), ctypes.c_double()
                ctx.check(lib.bst_metrics_accordance(c, pa, pb, 0, ci, j, ctypes.byref(g),
                                                     ctypes.byref(f), la[q].ctypes.data_as(dp)))
                ga[q], fa[q] = g.value, f.value
            r.ga[cname], r.fa[cname], r.la[cname] = ga, fa, la
            r.hem_a[cname], r.hem_b[cname] = h1[patches], h2[patches]
            r.ga_all[cname], r.fa_all[cname] = ga_all, fa_all
            comps.append(cname)
    if not comps:
        raise Error("neither BSDF holds %s" % ("the components asked for" if mask else "any component"))
    r.components = tuple(comps)
    r._keep = (ha, hb)
    return r
