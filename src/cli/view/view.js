/* view.js - the interactive page `bsdfstack view` writes (cmd_view.c): the embedded BSDF data
 * (JSON in #bsdf-data, view_data.c) drawn on canvases.
 *
 * Conventions, as the library's (include/bsdfstack.h) and `plot`'s: a component is a matrix,
 * column = incident patch (that of the light's propagation direction), row = exit patch, value =
 * BSDF in 1/sr.  Patches are found from a direction's x, y alone: Shirley-Chiu cells through
 * RADIANCE's concentric map, Klems patches by band and azimuth (basis.c).  The directional-
 * hemispherical value of a column is sum_i Lambda_i M(i, j) with the Lambda the file embeds,
 * as `info` sums it; a direction on a patch boundary takes the patch on the +x, +y side, as
 * info's table does.  Disks show exit directions at their x, y (radius sin theta): +X right,
 * +Y up, the window seen from its interior side.  The view's state is the URL fragment:
 * #incident=THETA,PHI&comp=Tf&channel=Visible&mode=side|la. */
"use strict";
(function () {
    const D = JSON.parse(document.getElementById("bsdf-data").textContent);
    const COMPS = ["Tf", "Rf", "Tb", "Rb"];
    const DEG = Math.PI / 180;
    const MAP = 400;             /* diameter of an exit disk, pixels */
    const PAD = 10;              /* margin of a map's canvas around the disk */
    const BAR = 110;             /* room for the colour bar and its labels */
    const DECADES = 4;           /* the log scale spans this far below the peak, as plot's */
    const NUDGE = 1e-9;          /* boundary rule: +x, +y side, as info's table */
    const $ = (id) => document.getElementById(id);
    /* x, y of the direction theta, phi (degrees) */
    const planar = (theta, phi) => [Math.sin(theta * DEG) * Math.cos(phi * DEG),
                                    Math.sin(theta * DEG) * Math.sin(phi * DEG)];

    /* ------------------------------------------------------------ data */

    function bytes(s) {
        const bin = atob(s), u = new Uint8Array(bin.length);
        for (let i = 0; i < bin.length; i++)
            u[i] = bin.charCodeAt(i);
        return u;
    }
    const f32 = (s) => new Float32Array(bytes(s).buffer);
    const f64 = (s) => new Float64Array(bytes(s).buffer);

    /* ------------------------------------------------------------ the basis */

    function polarToSquare(r, phi) {
        if (r === 0)
            return [0.5, 0.5];
        const q = Math.PI / 4;
        while (phi < -q)
            phi += 2 * Math.PI;
        while (phi >= 7 * q)
            phi -= 2 * Math.PI;
        let a, b;
        if (phi < q)
            a = r, b = r * phi / q;
        else if (phi < 3 * q)
            b = r, a = -r * (phi - Math.PI / 2) / q;
        else if (phi < 5 * q)
            a = -r, b = -r * (phi - Math.PI) / q;
        else
            b = -r, a = r * (phi - 3 * Math.PI / 2) / q;
        return [(a + 1) / 2, (b + 1) / 2];
    }

    function squareToDisk(sx, sy) {
        const a = 2 * sx - 1, b = 2 * sy - 1, q = Math.PI / 4;
        if (a === 0 && b === 0)
            return [0, 0];
        let r, phi;
        if (Math.abs(a) >= Math.abs(b))
            r = Math.abs(a), phi = a > 0 ? q * (b / a) : q * (4 + b / a);
        else
            r = Math.abs(b), phi = b > 0 ? q * (2 - a / b) : q * (6 - a / b);
        return [r * Math.cos(phi), r * Math.sin(phi)];
    }

    function scBasis(k) {
        const g = 1 << k, cell = (s) => Math.min(g - 1, Math.max(0, Math.floor(s * g)));
        return {
            n: g * g,
            patch(x, y) {
                const r = Math.hypot(x, y), s = polarToSquare(r, r === 0 ? 0 : Math.atan2(y, x));
                return cell(s[0]) * g + cell(s[1]);
            },
            center(p) { return squareToDisk((Math.floor(p / g) + 0.5) / g, (p % g + 0.5) / g); }
        };
    }

    function klemsBasis(theta, nphi) {
        const first = [0];
        for (let i = 0; i < nphi.length; i++)
            first.push(first[i] + nphi[i]);
        const band = (p) => { let b = 0; while (b + 1 < nphi.length && p >= first[b + 1]) b++; return b; };
        return {
            n: first[nphi.length],
            patch(x, y) {
                const t = Math.asin(Math.min(1, Math.hypot(x, y))) / DEG;
                let b = 0;
                while (b + 1 < nphi.length && t >= theta[b + 1])
                    b++;
                const n = nphi[b];
                let phi = Math.atan2(y, x) / DEG;
                if (phi < 0)
                    phi += 360;
                const j = Math.floor((phi + 180 / n) / (360 / n));
                return first[b] + ((j % n) + n) % n;
            },
            center(p) {
                const b = band(p);
                const t = (b === 0 && theta[0] === 0 && nphi[0] === 1 ? 0 : (theta[b] + theta[b + 1]) / 2) * DEG;
                const f = (p - first[b]) * 2 * Math.PI / nphi[b];
                return [Math.sin(t) * Math.cos(f), Math.sin(t) * Math.sin(f)];
            }
        };
    }

    const basis = D.basis.kind === "sc" ? scBasis(D.basis.k) : klemsBasis(D.basis.theta, D.basis.nphi);
    const N = basis.n;
    const lambda = f64(D.lambda);
    const cols = D.cols;         /* the embedded incident patches, or null: every one */
    const ncols = cols ? cols.length : N;

    /* A component of file f, channel c: its columns on demand (decoded once), or null (zero). */
    const decoded = new Map();
    function component(f, c, comp) {
        const key = f + "/" + c + "/" + comp;
        if (decoded.has(key))
            return decoded.get(key);
        const e = D.m[f][c][comp];
        let m = null;
        if (e && e.d)
            m = { dense: f32(e.d) };
        else if (e && e.p)
            m = { p: new Uint32Array(bytes(e.p).buffer), r: new Uint16Array(bytes(e.r).buffer), v: f32(e.v) };
        decoded.set(key, m);
        return m;
    }

    const scratch = new Float32Array(N);
    /* Column jc (an index into the embedded columns) of a component, as N values. */
    function column(m, jc) {
        if (m && m.dense)
            return m.dense.subarray(jc * N, (jc + 1) * N);
        scratch.fill(0);
        if (m)
            for (let q = m.p[jc]; q < m.p[jc + 1]; q++)
                scratch[m.r[q]] = m.v[q];
        return scratch;
    }

    function hemOf(col) {
        let s = 0;
        for (let i = 0; i < N; i++)
            s += lambda[i] * col[i];
        return s;
    }

    const hemCache = new Map();
    /* Directional-hemispherical values of every embedded column. */
    function hemAll(f, c, comp) {
        const key = f + "/" + c + "/" + comp;
        if (!hemCache.has(key)) {
            const m = component(f, c, comp), h = new Float64Array(ncols);
            for (let j = 0; j < ncols; j++)
                h[j] = m ? hemOf(column(m, j)) : 0;
            hemCache.set(key, h);
        }
        return hemCache.get(key);
    }

    /* The embedded column of a propagation direction (theta, phi in degrees): its patch's, or
     * with chosen columns the nearest of them. */
    function columnOf(theta, phi) {
        const [x, y] = planar(theta, phi);
        const p = basis.patch(x + NUDGE, y + NUDGE);
        if (!cols)
            return p;
        let best = 0, bd = Infinity;
        for (let j = 0; j < cols.length; j++) {
            if (cols[j] === p)
                return j;
            const c = basis.center(cols[j]), d = (c[0] - x) ** 2 + (c[1] - y) ** 2;
            if (d < bd)
                bd = d, best = j;
        }
        return best;
    }

    function direction(p) {
        const c = basis.center(p), r = Math.min(1, Math.hypot(c[0], c[1]));
        let phi = Math.atan2(c[1], c[0]) / DEG;
        if (phi < 0)
            phi += 360;
        return [Math.asin(r) / DEG, phi];
    }

    /* ------------------------------------------------------------ drawing */

    /* plot's colour ramp (draw.c): t in [0, 1] to RGB */
    const RAMP = [[0.0, 8, 8, 32], [0.2, 40, 40, 140], [0.4, 30, 120, 170], [0.6, 40, 175, 120],
                  [0.8, 200, 210, 60], [1.0, 255, 250, 200]];
    function ramp(t) {
        t = !(t > 0) ? 0 : t > 1 ? 1 : t;
        let i = 0;
        while (i < 4 && t > RAMP[i + 1][0])
            i++;
        const f = (t - RAMP[i][0]) / (RAMP[i + 1][0] - RAMP[i][0]);
        return [1, 2, 3].map((c) => Math.round(RAMP[i][c] + f * (RAMP[i + 1][c] - RAMP[i][c])));
    }
    /* the ramp in 256 steps (and white, at 256) as the canvas's RGBA bytes in one 32-bit word */
    const PACKED = new Uint32Array(257), bytes4 = new Uint8Array(PACKED.buffer);
    for (let i = 0; i <= 256; i++) {
        const c = i < 256 ? ramp(i / 255) : [255, 255, 255];
        bytes4.set([c[0], c[1], c[2], 255], 4 * i);
    }

    let pixelPatch = null;       /* exit patch of every pixel of a disk, -1 outside */
    function pixelPatches() {
        if (pixelPatch)
            return pixelPatch;
        pixelPatch = new Int32Array(MAP * MAP);
        const r = MAP / 2;
        for (let j = 0; j < MAP; j++)
            for (let i = 0; i < MAP; i++) {
                const x = (i + 0.5 - r) / r, y = (r - j - 0.5) / r;
                pixelPatch[j * MAP + i] = x * x + y * y > 1 ? -1 : basis.patch(x, y);
            }
        return pixelPatch;
    }

    /* A scale: log over DECADES below the peak (plot's default), or linear lo..hi. */
    function logScale(peak) {
        const hi = peak > 0 ? peak : 1, lo = hi * Math.pow(10, -DECADES);
        const span = Math.log10(hi) - Math.log10(lo);
        return { log: true, lo, hi, t: (v) => v <= lo ? 0 : (Math.log10(v) - Math.log10(lo)) / span };
    }
    const linearScale = (lo, hi) => ({ log: false, lo, hi, t: (v) => (v - lo) / (hi - lo) });

    function ticks(s) {
        const t = [];
        if (s.log) {
            for (let d = Math.ceil(Math.log10(s.lo) - 1e-9); d <= Math.floor(Math.log10(s.hi) + 1e-9); d++)
                t.push(Math.pow(10, d));
            return t.length >= 2 ? t : [s.lo, s.hi];
        }
        for (let v = s.lo; v <= s.hi + 1e-9; v += (s.hi - s.lo) / 4)
            t.push(v);
        return t;
    }

    /* Draw values (N, one per exit patch) on canvas cv with scale s, the specular mark at (mx, my). */
    function drawMap(cv, values, s, mark) {
        const g = cv.getContext("2d"), pp = pixelPatches(), img = g.createImageData(MAP, MAP);
        const px = new Uint32Array(img.data.buffer), colour = new Uint32Array(N);
        for (let i = 0; i < N; i++)
            colour[i] = PACKED[Math.round(255 * Math.min(1, Math.max(0, s.t(values[i]))) || 0)];
        const white = PACKED[256];
        for (let q = 0; q < MAP * MAP; q++)
            px[q] = pp[q] < 0 ? white : colour[pp[q]];
        g.fillStyle = "#fff";
        g.fillRect(0, 0, cv.width, cv.height);
        g.putImageData(img, PAD, PAD);
        const r = MAP / 2, cx = PAD + r, cy = PAD + r;
        g.strokeStyle = "#888";
        g.lineWidth = 1;
        for (const t of [30, 60, 90]) {
            g.beginPath();
            g.arc(cx, cy, r * Math.sin(t * DEG), 0, 2 * Math.PI);
            g.stroke();
        }
        if (mark) {
            const x = cx + r * mark[0], y = cy - r * mark[1];
            for (const [col, w] of [["#000", 3], ["#e01b24", 1.5]]) {
                g.strokeStyle = col, g.lineWidth = w;
                g.beginPath();
                g.arc(x, y, 8, 0, 2 * Math.PI);
                g.stroke();
            }
        }
        drawBar(g, s, PAD + MAP + 20, PAD, MAP);
    }

    function drawBar(g, s, x, y, h) {
        for (let j = 0; j < h; j++) {
            const c = ramp(1 - j / (h - 1));
            g.fillStyle = "rgb(" + c.join(",") + ")";
            g.fillRect(x, y + j, 18, 1);
        }
        g.fillStyle = "#111";
        g.font = "12px sans-serif";
        for (const v of ticks(s)) {
            const t = Math.min(1, Math.max(0, s.t(v)));
            const yy = y + (1 - t) * (h - 1);
            g.fillRect(x + 18, yy, 5, 1);
            g.fillText(s.log ? v.toExponential(0) : v.toFixed(0), x + 26, yy + 4);
        }
        g.fillText(s.log ? "1/sr" : "LA %", x, y + h + 8 > g.canvas.height ? y + h : y + h + 8);
    }

    /* ------------------------------------------------------------ the view */

    const state = { theta: 0, phi: 0, comp: "Tf", channel: D.channels[0], mode: "side" };

    function readHash() {
        const h = location.hash.replace(/^#/, "");
        for (const part of h.split("&")) {
            const eq = part.indexOf("="), k = part.slice(0, eq), v = decodeURIComponent(part.slice(eq + 1));
            if (k === "incident") {
                const a = v.split(",").map(Number);
                if (a.length === 2 && a.every(Number.isFinite))
                    state.theta = Math.min(89.9, Math.max(0, a[0])), state.phi = ((a[1] % 360) + 360) % 360;
            } else if (k === "comp" && COMPS.includes(v)) {
                state.comp = v;
            } else if (k === "channel") {
                const c = D.channels.find((n) => n.toLowerCase() === v.toLowerCase());
                if (c)
                    state.channel = c;
            } else if (k === "mode" && (v === "side" || v === "la")) {
                state.mode = v;
            }
        }
    }

    function writeHash() {
        const h = "#incident=" + +state.theta.toFixed(3) + "," + +state.phi.toFixed(3) + "&comp=" + state.comp +
              "&channel=" + encodeURIComponent(state.channel) + (state.mode === "la" ? "&mode=la" : "");
        if (location.hash !== h)
            try { history.replaceState(null, "", h); } catch (e) { /* a page without history */ }
    }

    function syncControls() {
        $("comp").value = state.comp;
        $("channel").value = state.channel;
        $("theta").value = +state.theta.toFixed(2);
        $("phi").value = +state.phi.toFixed(2);
        $("mode").value = state.mode;
    }

    function drawIncidence(jc) {
        const cv = $("incdisk"), g = cv.getContext("2d"), r = 100, cx = 110, cy = 110;
        g.clearRect(0, 0, cv.width, cv.height);
        g.strokeStyle = "#888";
        for (const t of [30, 60, 90]) {
            g.beginPath();
            g.arc(cx, cy, r * Math.sin(t * DEG), 0, 2 * Math.PI);
            g.stroke();
        }
        g.beginPath();
        g.moveTo(cx - r, cy), g.lineTo(cx + r, cy), g.moveTo(cx, cy - r), g.lineTo(cx, cy + r);
        g.stroke();
        g.fillStyle = "#1a5fb4";
        if (cols)
            for (const p of cols) {
                const c = basis.center(p);
                g.fillRect(cx + r * c[0] - 2, cy - r * c[1] - 2, 4, 4);
            }
        const [x, y] = planar(state.theta, state.phi);
        g.fillStyle = "#e01b24";
        g.beginPath();
        g.arc(cx + r * x, cy - r * y, 5, 0, 2 * Math.PI);
        g.fill();
        const d = direction(cols ? cols[jc] : jc);
        cv.setAttribute("aria-valuenow", state.theta.toFixed(1));
        cv.setAttribute("aria-valuetext", "theta " + state.theta.toFixed(1) + " degrees, phi " + state.phi.toFixed(1) +
                        " degrees; incident patch centre theta " + d[0].toFixed(1) + ", phi " + d[1].toFixed(1));
    }

    function figure(i, caption) {
        const maps = $("maps");
        let fig = maps.children[i];
        if (!fig) {
            fig = document.createElement("figure");
            const cv = document.createElement("canvas");
            cv.width = PAD + MAP + BAR, cv.height = MAP + 2 * PAD + 10;
            cv.setAttribute("role", "img");
            fig.append(cv, document.createElement("figcaption"));
            maps.append(fig);
        }
        fig.lastChild.textContent = caption;
        fig.firstChild.setAttribute("aria-label", caption);
        return fig.firstChild;
    }

    const fmt = (v) => v.toFixed(6);

    /* Draw the view.  body's data-draw-ms: how long the maps took (a column's values, its sums,
     * the pixels), once the one-time work (decoding, the pixels' patches) is done. */
    function render() {
        const c = D.channels.indexOf(state.channel), jc = columnOf(state.theta, state.phi);
        pixelPatches();
        for (let f = 0; f < D.files.length; f++)
            component(f, c, state.comp);
        const t0 = performance.now();
        const inc = direction(cols ? cols[jc] : jc), front = state.comp[1] === "f";
        const mark = planar(state.theta, state.phi);
        drawIncidence(jc);
        $("what").textContent = state.comp + ", channel " + state.channel + ", incidence (\u03b8, \u03c6) = (" +
            state.theta.toFixed(1) + ", " + state.phi.toFixed(1) + ")\u00b0, incident patch " + (cols ? cols[jc] : jc) +
            " centred at (" + inc[0].toFixed(1) + ", " + inc[1].toFixed(1) + ")\u00b0, " +
            (front ? "front" : "back") + " side";
        const res = [];
        for (let f = 0; f < D.files.length; f++) {
            const m = component(f, c, state.comp), col = column(m, jc).slice();
            let pk = 0;
            for (let i = 1; i < N; i++)
                if (col[i] > col[pk])
                    pk = i;
            res.push({ col, hem: hemOf(col), peak: col[pk], dir: direction(pk), absent: !m });
        }
        $("hem").textContent = fmt(res[0].hem);
        $("peakval").textContent = res[0].peak.toPrecision(6);
        $("peak").textContent = res[0].dir[0].toFixed(1) + "," + res[0].dir[1].toFixed(1);
        const others = $("others");
        others.textContent = "";
        for (let f = 1; f < res.length; f++) {
            const p = document.createElement("p");
            p.append(D.files[f].name + ": hemispherical ",
                     Object.assign(document.createElement("output"), { id: "hem-" + f, textContent: fmt(res[f].hem) }),
                     ", first file minus this ",
                     Object.assign(document.createElement("output"),
                                   { id: "hemdiff-" + f, textContent: fmt(res[0].hem - res[f].hem) }),
                     ", peak " + res[f].peak.toPrecision(4) + " 1/sr at (" + res[f].dir[0].toFixed(1) + ", " +
                     res[f].dir[1].toFixed(1) + ")\u00b0");
            others.append(p);
        }
        const maps = $("maps");
        let shown = 0;
        for (let f = 0; f < res.length; f++) {
            const r = res[f], name = D.files[f].name;
            if (state.mode === "la" && f > 0) {
                const a = res[0].col, b = r.col, la = new Float64Array(N);
                for (let i = 0; i < N; i++)
                    la[i] = a[i] + b[i] > 0 ? 100 * (1 - Math.abs(a[i] - b[i]) / (a[i] + b[i])) : 100;
                drawMap(figure(shown++, "Local accordance LA (%) of " + D.files[0].name + " and " + name + ", " +
                               state.comp + ", " + state.channel + " (Grobe 2017, eq. 8)"),
                        la, linearScale(0, 100), mark);
            } else {
                drawMap(figure(shown++, name + ": " + state.comp + ", " + state.channel + ", BSDF (1/sr), log scale " +
                               DECADES + " decades below the peak; hemispherical " + fmt(r.hem) +
                               (r.absent ? " (component absent: zero)" : "")),
                        r.col, logScale(r.peak), mark);
            }
        }
        while (maps.children.length > shown)
            maps.lastChild.remove();
        document.body.dataset.drawMs = (performance.now() - t0).toFixed(1);
        const rect = maps.firstChild.firstChild.getBoundingClientRect();
        $("mapdisk").textContent = (rect.left + scrollX + PAD + MAP / 2) + " " +
            (rect.top + scrollY + PAD + MAP / 2) + " " + MAP / 2;
        drawCurves(c, front);
        writeHash();
    }

    /* ------------------------------------------------------------ T and R against theta */

    const FILE_COLOURS = ["#1a5fb4", "#c01c28", "#26a269", "#a347ba", "#e66100", "#63452c"];

    function drawCurves(c, front) {
        const cv = $("curves"), g = cv.getContext("2d"), L = 60, R = 200, T = 12, B = 36;
        const w = cv.width - L - R, h = cv.height - T - B;
        $("curvephi").textContent = state.phi.toFixed(1);
        g.fillStyle = "#fff";
        g.fillRect(0, 0, cv.width, cv.height);
        g.fillStyle = "#111";
        g.font = "12px sans-serif";
        if (cols) {
            g.fillText("Only the chosen incident directions are embedded: no curves.", L, T + 20);
            return;
        }
        const comps = front ? ["Tf", "Rf"] : ["Tb", "Rb"], series = [];
        let ymax = 0;
        for (let f = 0; f < D.files.length; f++)
            for (const comp of comps) {
                const hem = hemAll(f, c, comp), pts = [];
                for (let t = 0; t <= 89.9; t += 0.1) {
                    const v = hem[columnOf(t, state.phi)];
                    pts.push([t, v]);
                    ymax = Math.max(ymax, v);
                }
                series.push({ f, comp, pts });
            }
        ymax = ymax > 0 ? Math.ceil(ymax * 10 - 1e-9) / 10 : 1;
        const X = (t) => L + w * t / 90, Y = (v) => T + h * (1 - v / ymax);
        g.strokeStyle = "#ccc";
        for (let i = 0; i <= 5; i++) {
            g.beginPath(), g.moveTo(L, Y(ymax * i / 5)), g.lineTo(L + w, Y(ymax * i / 5)), g.stroke();
            g.fillText((ymax * i / 5).toFixed(2), 8, Y(ymax * i / 5) + 4);
        }
        for (let t = 0; t <= 90; t += 15) {
            g.beginPath(), g.moveTo(X(t), T), g.lineTo(X(t), T + h), g.stroke();
            g.fillText(t + "\u00b0", X(t) - 8, T + h + 16);
        }
        g.fillText("incidence \u03b8", L + w / 2 - 30, T + h + 32);
        series.forEach((s, i) => {
            g.strokeStyle = FILE_COLOURS[s.f % FILE_COLOURS.length];
            g.lineWidth = 2;
            g.setLineDash(s.comp[0] === "T" ? [] : [6, 4]);
            g.beginPath();
            s.pts.forEach(([t, v], k) => k ? g.lineTo(X(t), Y(v)) : g.moveTo(X(t), Y(v)));
            g.stroke();
            g.beginPath(), g.moveTo(L + w + 12, T + 10 + 18 * i), g.lineTo(L + w + 40, T + 10 + 18 * i), g.stroke();
            g.fillText(s.comp + " " + D.files[s.f].name.slice(0, 22), L + w + 46, T + 14 + 18 * i);
        });
        g.setLineDash([]);
        g.lineWidth = 1;
    }

    /* ------------------------------------------------------------ input */

    function setIncidence(theta, phi) {
        state.theta = Math.min(89.9, Math.max(0, theta));
        state.phi = ((phi % 360) + 360) % 360;
        syncControls();
        render();
    }

    function pointer(ev) {
        const cv = $("incdisk"), rect = cv.getBoundingClientRect();
        const x = (ev.clientX - rect.left - 110) / 100, y = (110 - (ev.clientY - rect.top)) / 100;
        const rho = Math.min(1, Math.hypot(x, y));
        setIncidence(Math.asin(rho) / DEG, rho > 0 ? Math.atan2(y, x) / DEG : state.phi);
    }

    function setup() {
        $("files").textContent = D.files.map((f, i) => (i + 1) + ". " + f.name + " (" + f.format + ")").join("; ") +
            "; shown over " + D.basis.name + (cols ? ", " + cols.length + " incident directions" : "");
        $("note").textContent = D.note || "";
        for (const name of D.channels)
            $("channel").append(new Option(name, name));
        if (D.files.length < 2)
            $("mode").disabled = true;
        const cv = $("incdisk");
        let dragging = false;
        cv.addEventListener("pointerdown", (ev) => {
            dragging = true;
            cv.setPointerCapture(ev.pointerId);
            pointer(ev);
        });
        cv.addEventListener("pointermove", (ev) => { if (dragging) pointer(ev); });
        cv.addEventListener("pointerup", () => { dragging = false; });
        cv.addEventListener("keydown", (ev) => {
            const step = ev.shiftKey ? 5 : 1;
            const keys = { ArrowUp: [step, 0], ArrowDown: [-step, 0], ArrowRight: [0, step], ArrowLeft: [0, -step] };
            const k = keys[ev.key];
            if (k) {
                ev.preventDefault();
                setIncidence(state.theta + k[0], state.phi + k[1]);
            }
        });
        $("comp").addEventListener("change", (ev) => { state.comp = ev.target.value; render(); });
        $("channel").addEventListener("change", (ev) => { state.channel = ev.target.value; render(); });
        $("mode").addEventListener("change", (ev) => { state.mode = ev.target.value; render(); });
        for (const id of ["theta", "phi"])
            $(id).addEventListener("change", () => {
                const t = Number($("theta").value), p = Number($("phi").value);
                if (Number.isFinite(t) && Number.isFinite(p))
                    setIncidence(t, p);
            });
        $("controls").addEventListener("submit", (ev) => ev.preventDefault());
        window.addEventListener("hashchange", () => { readHash(); syncControls(); render(); });
        readHash();
        syncControls();
        render();
        document.body.dataset.ready = "1";
    }

    setup();
})();
