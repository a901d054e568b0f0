// The image viewer of report.html: the reference, every variant at every budget, and the
// parameter grid's cells. The images are HDR: half floats (planar R, G, B; all high
// bytes, then all low bytes; zlib) in the `stokes-images` JSON. Display: linear value × 2^stops,
// then the sRGB transfer function, 8 bits; the relative-error view colours
// √(mean over R, G, B of (x − r)² / (r² + ε)) on the log ramp of the figures' error maps.
// Keys: ← → and 1–9 choose the method, ↑ ↓ the budget, e the error view, f or 0 fits the image,
// + − change the exposure by half a stop, a sets it automatically. Wheel zooms about the cursor,
// dragging pans; the view is the same for every method.
(function () {
  'use strict';
  var data = JSON.parse(document.getElementById('stokes-images').textContent);
  var W = data.width, H = data.height, N = W * H;
  var EPS = data.rel_eps;
  // The false-colour ramp of the figures (black → purple → orange → yellow).
  var RAMP = [[0, 0, 0.02], [0.34, 0.06, 0.43], [0.73, 0.21, 0.33], [0.98, 0.55, 0.04], [0.99, 1, 0.64]];
  var MAGENTA = [255, 0, 255];

  var el = function (id) { return document.getElementById(id); };
  var canvas = el('view'), caption = el('caption'), slider = el('exposure');
  var ctx = canvas.getContext('2d', { willReadFrequently: true });
  var off = document.createElement('canvas');
  off.width = W;
  off.height = H;
  var offCtx = off.getContext('2d', { willReadFrequently: true });
  var frame = offCtx.createImageData(W, H);

  var methods = [];
  if (data.reference) {
    methods.push({ name: 'reference', about: data.reference.about, reference: true });
  }
  data.variants.forEach(function (v) {
    methods.push({ name: v.name, about: v.integrator, images: v.images });
  });
  data.cells.forEach(function (c) {
    methods.push({ name: c.name, about: c.about, single: c });
  });
  var state = {
    method: 0, budget: data.budgets.length - 1, exposure: 0, error: false,
    scale: 1, ox: 0, oy: 0, moved: false, ready: false
  };
  var pixels = new Map(); // image record → Float32Array, planar R, G, B

  function current() {
    var m = methods[state.method];
    return m.reference ? data.reference : m.single || m.images[state.budget];
  }

  // Half float bits → value.
  var F16 = new Float32Array(65536);
  (function () {
    for (var h = 0; h < 65536; h++) {
      var s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 31, f = h & 1023;
      F16[h] = e === 0 ? s * f * Math.pow(2, -24)
        : e === 31 ? (f ? NaN : s * Infinity)
          : s * (1 + f / 1024) * Math.pow(2, e - 15);
    }
  })();

  function bytes(b64) {
    var s = atob(b64), out = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out;
  }

  function decode(img) {
    var stream = new Blob([bytes(img.data)]).stream()
      .pipeThrough(new DecompressionStream('deflate'));
    return new Response(stream).arrayBuffer().then(function (buf) {
      var raw = new Uint8Array(buf), n = 3 * N;
      if (raw.length !== 2 * n) {
        throw new Error(img.file + ': ' + raw.length + ' bytes, expected ' + 2 * n);
      }
      var px = new Float32Array(n);
      for (var i = 0; i < n; i++) px[i] = F16[(raw[i] << 8) | raw[n + i]];
      pixels.set(img, px);
      img.data = null;
    });
  }

  function srgb8(x) {
    if (!(x > 0)) return 0;
    if (x >= 1) return 255;
    var v = x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
    return Math.round(v * 255);
  }

  function ramp(t, d, o) {
    t = Math.min(Math.max(t, 0), 1) * 4;
    var i = Math.min(Math.floor(t), 3), f = t - i;
    for (var k = 0; k < 3; k++) {
      d[o + k] = Math.floor((RAMP[i][k] * (1 - f) + RAMP[i + 1][k] * f) * 255);
    }
  }

  function relError(px, ref, i) {
    var e = 0;
    for (var c = 0; c < 3; c++) {
      var x = px[c * N + i], r = ref[c * N + i], d = x - r;
      e += d * d / (r * r + EPS);
    }
    return Math.sqrt(e / 3);
  }

  // The current image at native size into `off`.
  function render() {
    var px = pixels.get(current()), d = frame.data, k = Math.pow(2, state.exposure);
    var ref = state.error && data.reference ? pixels.get(data.reference) : null;
    for (var i = 0; i < N; i++) {
      var o = 4 * i, r = px[i], g = px[N + i], b = px[2 * N + i];
      d[o + 3] = 255;
      if (ref) {
        var e = relError(px, ref, i);
        if (isFinite(e)) ramp((Math.log10(Math.max(e, 1e-3)) + 3) / 3, d, o);
        else d.set(MAGENTA, o);
      } else if (isFinite(r) && isFinite(g) && isFinite(b)) {
        d[o] = srgb8(r * k);
        d[o + 1] = srgb8(g * k);
        d[o + 2] = srgb8(b * k);
      } else {
        d.set(MAGENTA, o);
      }
    }
    offCtx.putImageData(frame, 0, 0);
  }

  // `off` onto the visible canvas at the view's scale and offset, nearest pixel.
  function blit() {
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(off, state.ox, state.oy, W * state.scale, H * state.scale);
  }

  function fit() {
    var s = Math.min(canvas.width / W, canvas.height / H);
    if (s >= 1) s = Math.floor(s);
    state.scale = s;
    state.ox = Math.round((canvas.width - W * s) / 2);
    state.oy = Math.round((canvas.height - H * s) / 2);
    state.moved = false;
  }

  function resize() {
    var dpr = window.devicePixelRatio || 1;
    var w = Math.max(1, Math.round(canvas.clientWidth * dpr));
    var h = Math.max(1, Math.round(canvas.clientHeight * dpr));
    if (w === canvas.width && h === canvas.height) return;
    var cx = (canvas.width / 2 - state.ox) / state.scale;
    var cy = (canvas.height / 2 - state.oy) / state.scale;
    canvas.width = w;
    canvas.height = h;
    if (state.moved) {
      state.ox = Math.round(w / 2 - cx * state.scale);
      state.oy = Math.round(h / 2 - cy * state.scale);
    } else {
      fit();
    }
    if (state.ready) blit();
  }

  function fmt(x, digits) {
    return x === null || x === undefined ? '–' : Number(x).toFixed(digits);
  }

  function describe() {
    var m = methods[state.method];
    var t = (state.method + 1) + '. ' + m.name;
    if (m.reference || m.single) {
      t += m.about ? ' · ' + m.about : '';
    } else {
      var img = current(), b = data.budgets[state.budget], mt = img.metrics;
      t += (m.about !== m.name ? ' (' + m.about + ')' : '') + ' · budget ' + b.label;
      if (mt) {
        t += ' · ' + mt.spp + ' spp in ' + fmt(mt.seconds, 2) + ' s · SNR ' + fmt(mt.snr_db, 2) +
          ' dB · relMSE ' + (mt.rel_mse === null ? '–' : mt.rel_mse.toExponential(2));
      }
    }
    if (state.error) t += ' — relative error to the reference';
    return t;
  }

  var methodButtons = [], budgetButtons = [];

  function ui() {
    methodButtons.forEach(function (b, i) { b.classList.toggle('active', i === state.method); });
    budgetButtons.forEach(function (b, i) { b.classList.toggle('active', i === state.budget); });
    el('error-toggle').classList.toggle('active', state.error);
    el('legend').hidden = !state.error;
    el('exposure-value').textContent = (state.exposure >= 0 ? '+' : '') +
      state.exposure.toFixed(1) + ' stops';
    caption.textContent = describe();
  }

  function update() {
    if (!state.ready) return;
    render();
    blit();
    ui();
  }

  function setMethod(i) {
    state.method = (i + methods.length) % methods.length;
    update();
  }

  function setBudget(j) {
    state.budget = Math.min(Math.max(j, 0), data.budgets.length - 1);
    update();
  }

  function setExposure(v) {
    var lo = parseFloat(slider.min), hi = parseFloat(slider.max);
    state.exposure = Math.round(Math.min(Math.max(v, lo), hi) * 10) / 10;
    slider.value = String(state.exposure);
    update();
  }

  function toggleError() {
    state.error = !!data.reference && !state.error;
    update();
  }

  // Stops that put the 99th percentile of the reference's (else the image's) brightest channel
  // at 1, as the figures expose.
  function autoExposure() {
    var px = pixels.get(data.reference || current()), v = [];
    for (var i = 0; i < N; i++) {
      var m = Math.max(px[i], px[N + i], px[2 * N + i]);
      if (isFinite(m) && m > 0) v.push(m);
    }
    if (!v.length) return 0;
    v.sort(function (a, b) { return a - b; });
    return -Math.log2(Math.max(v[Math.floor(v.length * 0.99)], 1e-12));
  }

  function buttons() {
    methods.forEach(function (m, i) {
      var b = document.createElement('button');
      b.type = 'button';
      b.textContent = (i < 9 ? (i + 1) + '  ' : '') + m.name;
      b.title = m.about || '';
      b.addEventListener('click', function () { setMethod(i); });
      el('methods').appendChild(b);
      methodButtons.push(b);
    });
    data.budgets.forEach(function (bd, j) {
      var b = document.createElement('button');
      b.type = 'button';
      b.textContent = bd.label;
      b.addEventListener('click', function () { setBudget(j); });
      el('budgets').appendChild(b);
      budgetButtons.push(b);
    });
    el('error-toggle').disabled = !data.reference;
    el('error-toggle').addEventListener('click', toggleError);
    el('fit').addEventListener('click', function () { fit(); blit(); });
    el('auto-exposure').addEventListener('click', function () { setExposure(autoExposure()); });
    slider.addEventListener('input', function () { setExposure(parseFloat(slider.value)); });
  }

  function onKey(e) {
    if (!state.ready || e.ctrlKey || e.metaKey || e.altKey) return;
    var t = e.target && e.target.tagName;
    if (t === 'INPUT' || t === 'SELECT' || t === 'TEXTAREA') return;
    var k = e.key, used = true;
    if (k === 'ArrowRight') setMethod(state.method + 1);
    else if (k === 'ArrowLeft') setMethod(state.method - 1);
    else if (k === 'ArrowUp') setBudget(state.budget + 1);
    else if (k === 'ArrowDown') setBudget(state.budget - 1);
    else if (k.length === 1 && k >= '1' && k <= '9') {
      if (+k <= methods.length) setMethod(+k - 1);
    } else if (k === 'e' || k === 'E') toggleError();
    else if (k === 'f' || k === 'F' || k === '0') { fit(); blit(); }
    else if (k === '+' || k === '=') setExposure(state.exposure + 0.5);
    else if (k === '-' || k === '_') setExposure(state.exposure - 0.5);
    else if (k === 'a' || k === 'A') setExposure(autoExposure());
    else used = false;
    if (used) e.preventDefault();
  }

  // Canvas device pixel under a mouse event.
  function devicePoint(e) {
    var r = canvas.getBoundingClientRect();
    return [(e.clientX - r.left) * canvas.width / r.width, (e.clientY - r.top) * canvas.height / r.height];
  }

  function onWheel(e) {
    e.preventDefault();
    if (!state.ready || !e.deltaY) return;
    var p = devicePoint(e);
    var u = (p[0] - state.ox) / state.scale, v = (p[1] - state.oy) / state.scale;
    var s = Math.min(Math.max(state.scale * (e.deltaY < 0 ? 1.25 : 0.8), 0.05), 512);
    state.scale = s;
    state.ox = Math.round(p[0] - u * s);
    state.oy = Math.round(p[1] - v * s);
    state.moved = true;
    blit();
  }

  var drag = null;

  function onMove(e) {
    if (drag) {
      var p = devicePoint(e);
      state.ox += Math.round(p[0] - drag[0]);
      state.oy += Math.round(p[1] - drag[1]);
      drag = [drag[0] + Math.round(p[0] - drag[0]), drag[1] + Math.round(p[1] - drag[1])];
      state.moved = true;
      blit();
    }
    if (e.target === canvas && state.ready) showPixel(devicePoint(e));
  }

  function showPixel(p) {
    var x = Math.floor((p[0] - state.ox) / state.scale), y = Math.floor((p[1] - state.oy) / state.scale);
    if (x < 0 || y < 0 || x >= W || y >= H) {
      el('pixel').textContent = '\u00a0';
      return;
    }
    var i = y * W + x, px = pixels.get(current());
    var rgb = function (a) {
      return [a[i], a[N + i], a[2 * N + i]].map(function (v) { return v.toPrecision(4); }).join(' ');
    };
    var t = 'pixel (' + x + ', ' + y + ')  linear RGB ' + rgb(px);
    if (data.reference) {
      var ref = pixels.get(data.reference);
      t += '   reference ' + rgb(ref) + '   relative error ' + relError(px, ref, i).toPrecision(3);
    }
    el('pixel').textContent = t;
  }

  function listen() {
    document.addEventListener('keydown', onKey);
    canvas.addEventListener('wheel', onWheel, { passive: false });
    canvas.addEventListener('mousedown', function (e) {
      if (e.button !== 0) return;
      drag = devicePoint(e);
      canvas.classList.add('dragging');
      e.preventDefault();
    });
    window.addEventListener('mousemove', onMove);
    window.addEventListener('mouseup', function () {
      drag = null;
      canvas.classList.remove('dragging');
    });
    window.addEventListener('resize', resize);
    var region = el('region-select');
    if (region) {
      var show = function () {
        document.querySelectorAll('table.metrics').forEach(function (t) {
          t.hidden = t.getAttribute('data-region') !== region.value;
        });
      };
      region.addEventListener('change', show);
      show();
    }
  }

  function start() {
    buttons();
    listen();
    resize();
    var all = data.reference ? [data.reference] : [];
    data.variants.forEach(function (v) { all = all.concat(v.images); });
    all = all.concat(data.cells);
    if (typeof DecompressionStream === 'undefined') {
      caption.textContent = 'This browser cannot inflate the images (it has no DecompressionStream; ' +
        'Chrome 80, Firefox 113 and Safari 16.4 have it).';
      document.documentElement.setAttribute('data-viewer', 'failed');
      return;
    }
    caption.textContent = 'decoding ' + all.length + ' images…';
    Promise.all(all.map(decode)).then(function () {
      state.ready = true;
      setExposure(autoExposure());
      document.documentElement.setAttribute('data-viewer', 'ready');
      window.dispatchEvent(new Event('stokes-ready'));
    }, function (err) {
      caption.textContent = 'cannot decode the images: ' + err;
      document.documentElement.setAttribute('data-viewer', 'failed');
      console.error('report viewer: ' + err);
    });
  }

  if (methods.length) start();
  else caption.textContent = 'This run has no images.';
})();
