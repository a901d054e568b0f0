// report.html#selftest: once the viewer has decoded its images, drive it through the events a
// user makes (key presses, the exposure slider's `input`, a button click, wheel and drag on the
// canvas), read the canvas back after each and write the checks as JSON into the element
// #selftest (tests/report_browser.rs reads it from the DOM that a headless browser dumps).
(function () {
  'use strict';
  if (location.hash !== '#selftest') return;
  var out = document.getElementById('selftest');
  var canvas = document.getElementById('view');
  var slider = document.getElementById('exposure');
  var checks = [];

  function check(name, ok, detail) {
    checks.push({ name: name, ok: !!ok, detail: detail === undefined ? null : detail });
  }

  // A check this page cannot make (one image only, no reference): recorded, not passed.
  function skip(name, why) {
    checks.push({ name: name, ok: true, skipped: why });
  }

  function read() {
    return canvas.getContext('2d', { willReadFrequently: true })
      .getImageData(0, 0, canvas.width, canvas.height);
  }

  function differing(a, b) {
    var n = 0;
    for (var i = 0; i < a.data.length; i++) if (a.data[i] !== b.data[i]) n++;
    return n;
  }

  // Bounding box of the opaque (image) pixels: [left, top, right, bottom], right/bottom excluded.
  function box(img) {
    var w = img.width, h = img.height, b = [w, h, 0, 0];
    for (var y = 0; y < h; y++) {
      for (var x = 0; x < w; x++) {
        if (img.data[4 * (y * w + x) + 3] === 255) {
          b[0] = Math.min(b[0], x); b[1] = Math.min(b[1], y);
          b[2] = Math.max(b[2], x + 1); b[3] = Math.max(b[3], y + 1);
        }
      }
    }
    return b;
  }

  function same(a, b) { return a.join() === b.join(); }

  function key(k) {
    document.body.dispatchEvent(new KeyboardEvent('keydown', { key: k, bubbles: true, cancelable: true }));
  }

  function caption() { return document.getElementById('caption').textContent; }

  function setSlider(v) {
    slider.value = String(v);
    slider.dispatchEvent(new Event('input', { bubbles: true }));
  }

  function mouse(type, target, x, y) {
    target.dispatchEvent(new MouseEvent(type, {
      clientX: x, clientY: y, button: 0, bubbles: true, cancelable: true
    }));
  }

  // An 8-bit sRGB value back to linear.
  function lin(v) {
    v /= 255;
    return v <= 0.04045 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4);
  }

  // +1 stop must double every linear value. Each 8-bit value is the true one rounded, so it is
  // off by at most half a step: a channel passes when the intervals [a ± ½] doubled and [b ± ½]
  // (in linear) overlap. Near black (a < 24, where half a step is over 2 % of the value) and
  // clipped (b = 255) channels are skipped.
  function doubling(a, b) {
    var r = { channels: 0, failed: 0, worst_ratio_error: 0, first_failure: null };
    var slack = 1 + 1e-9;
    for (var i = 0; i < a.data.length; i += 4) {
      if (a.data[i + 3] !== 255 || b.data[i + 3] !== 255) continue;
      for (var c = 0; c < 3; c++) {
        var x = a.data[i + c], y = b.data[i + c];
        if (x < 24 || y === 255) continue;
        r.channels++;
        var ratio = lin(y) / lin(x);
        r.worst_ratio_error = Math.max(r.worst_ratio_error, Math.abs(ratio / 2 - 1));
        var ok = 2 * lin(x - 0.5) <= lin(y + 0.5) * slack && lin(y - 0.5) <= 2 * lin(x + 0.5) * slack;
        if (!ok) {
          r.failed++;
          if (!r.first_failure) r.first_failure = { pixel: i / 4, channel: c, before: x, after: y, ratio: ratio };
        }
      }
    }
    return r;
  }

  function exposureChecks(a) {
    var v0 = parseFloat(slider.value);
    setSlider(v0 + 1);
    var b = read();
    var d = doubling(a, b);
    d.stops_before = v0;
    d.stops_after = parseFloat(slider.value);
    check('exposure +1 stop doubles the linear values', d.channels >= 100 && d.failed === 0, d);
    setSlider(v0);
    check('exposure back to the start restores the canvas', differing(read(), a) === 0);
  }

  function flipChecks(a) {
    var n = document.querySelectorAll('#methods button').length, c0 = caption();
    if (n < 2) {
      skip('flipping between methods', 'the report shows one image');
      return;
    }
    key('ArrowRight');
    var f = read();
    check('ArrowRight flips to another method and the canvas changes',
      n > 1 && differing(f, a) > 0 && caption() !== c0,
      { methods: n, changed_bytes: differing(f, a), caption: caption() });
    check('the view stays when flipping', same(box(f), box(a)), { before: box(a), after: box(f) });
    key('ArrowLeft');
    check('ArrowLeft flips back', differing(read(), a) === 0 && caption() === c0);
    var last = document.querySelectorAll('#methods button')[n - 1];
    last.click();
    check('the method list flips', last.classList.contains('active') && caption() !== c0, caption());
    key('1');
    check('key 1 flips to the first method', differing(read(), a) === 0 && caption() === c0);
    if (document.getElementById('error-toggle').disabled) {
      skip('the relative error view', 'the run has no reference');
      return;
    }
    key('ArrowRight');
    var g = read();
    key('e');
    var e = read();
    check('e shows the relative error with its legend',
      differing(e, g) > 0 && !document.getElementById('legend').hidden, caption());
    key('e');
    check('e again shows the image', differing(read(), g) === 0);
    key('ArrowLeft');
  }

  function viewChecks(a) {
    var r = canvas.getBoundingClientRect(), dpr = canvas.width / r.width;
    var b0 = box(a);
    var x = r.left + r.width / 2, y = r.top + r.height / 2;
    mouse('mousedown', canvas, x, y);
    mouse('mousemove', window, x + 37, y + 23);
    mouse('mouseup', window, x + 37, y + 23);
    var p = read(), b1 = box(p);
    check('dragging pans the image',
      b1[0] === b0[0] + Math.round(37 * dpr) && b1[1] === b0[1] + Math.round(23 * dpr),
      { before: b0, after: b1 });
    var n = document.querySelectorAll('#methods button').length;
    if (n > 1) {
      key('ArrowRight');
      check('the pan stays when flipping', same(box(read()), b1));
      key('ArrowLeft');
      check('flipping back shows the same panned view', differing(read(), p) === 0);
    }
    canvas.dispatchEvent(new WheelEvent('wheel', {
      deltaY: -100, clientX: x, clientY: y, bubbles: true, cancelable: true
    }));
    var z = read(), bz = box(z);
    check('the wheel zooms in', bz[2] - bz[0] > b1[2] - b1[0] || bz[3] - bz[1] > b1[3] - b1[1],
      { before: b1, after: bz });
    if (n > 1) {
      key('ArrowRight');
      check('the zoom stays when flipping', same(box(read()), bz));
      key('ArrowLeft');
      check('flipping back shows the same zoomed view', differing(read(), z) === 0);
    }
    key('f');
    check('f fits the image again', differing(read(), a) === 0);
  }

  function run() {
    try {
      var a = read(), b = box(a);
      check('the canvas shows the image', b[2] > b[0] && b[3] > b[1], { box: b, canvas: [a.width, a.height] });
      exposureChecks(a);
      flipChecks(a);
      viewChecks(a);
    } catch (err) {
      check('the self-test ran to the end', false, String(err && err.stack || err));
    }
    finish();
  }

  function finish() {
    var errors = (window.stokesErrors || []).slice();
    var ok = checks.length > 0 && errors.length === 0 && checks.every(function (c) { return c.ok; });
    out.textContent = JSON.stringify({ ok: ok, checks: checks, errors: errors }, null, 1);
    out.hidden = false;
  }

  var state = document.documentElement.getAttribute('data-viewer');
  if (state === 'ready') run();
  else if (state === 'failed') {
    check('the viewer decoded its images', false, document.getElementById('caption').textContent);
    finish();
  } else {
    window.addEventListener('stokes-ready', run);
    // A viewer that fails after this script ran.
    new MutationObserver(function () {
      if (document.documentElement.getAttribute('data-viewer') === 'failed' && !checks.length) {
        check('the viewer decoded its images', false, document.getElementById('caption').textContent);
        finish();
      }
    }).observe(document.documentElement, { attributes: true });
  }
})();
