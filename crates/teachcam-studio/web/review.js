// teachcam review: draws the figure slots of the report model (`teachcam::report`) with uPlot.
//
//   window.teachcamReview.draw(container, figures)
//
// replaces whatever `container` holds with one <section class="tc-figure" data-figure=ID> per
// slot: its title, its plots (zoom by dragging, double-click to reset, values under the cursor
// in the legend), its images, or the line saying why it is missing; then its caption. Calling
// it again redraws (the old plots are destroyed). Needs window.uPlot; nothing else, no network.
// Used by the report page and by the studio's Review tab.
(function () {
  'use strict';

  var ROLE_COLOURS = {
    raw: '#1f77b4',
    smoothed: '#d62728',
    truth: '#2ca02c',
    residual: '#9467bd',
    predicted: '#ff7f0e',
    limit: '#7f7f7f',
    reference: '#000000'
  };
  var COMPONENT_COLOURS = ['#1f77b4', '#d62728', '#ff7f0e', '#9467bd', '#8c564b', '#17becf'];
  // A short panel is tall enough for three ticks with values and its whole y label.
  var HEIGHTS = { wide: 220, short: 170 };
  var STYLE_ID = 'teachcam-review-style';
  var CSS =
    '.tc-figure{margin:0 0 2.5em}' +
    '.tc-figure h2{font-size:1.25em;margin:.2em 0 .5em}' +
    '.tc-panel{margin:0 0 .8em}' +
    '.tc-row{display:flex;flex-wrap:wrap;gap:12px}' +
    '.tc-panel-title{font-size:.9em;color:#333;margin:.2em 0}' +
    '.tc-missing{color:#8a4b00;background:#fff6e5;border-left:4px solid #e0a030;padding:.4em .8em}' +
    '.tc-caption{color:#555;margin:.4em 0 0;max-width:60em}' +
    '.tc-readout{font:12px monospace;color:#333;min-height:1.2em}' +
    '.tc-images{display:flex;flex-wrap:wrap;gap:10px}' +
    '.tc-images figure{margin:0;flex:1 1 280px;max-width:420px}' +
    '.tc-images img{width:100%;height:auto;border:1px solid #ddd;image-rendering:pixelated}' +
    '.tc-images figcaption{font-size:.85em;color:#555}';

  function colour(role) {
    if (role && typeof role === 'object') {
      return COMPONENT_COLOURS[(role.component || 0) % COMPONENT_COLOURS.length];
    }
    return ROLE_COLOURS[role] || '#333333';
  }

  function element(tag, className, text) {
    var e = document.createElement(tag);
    if (className) e.className = className;
    if (text !== undefined) e.textContent = text;
    return e;
  }

  function axisLabel(axis) {
    return axis.unit ? axis.label + ' (' + axis.unit + ')' : axis.label;
  }

  function ensureStyle() {
    if (document.getElementById(STYLE_ID)) return;
    var style = element('style');
    style.id = STYLE_ID;
    style.textContent = CSS;
    document.head.appendChild(style);
  }

  function format(v) {
    if (v === null || v === undefined || !isFinite(v)) return '–';
    var a = Math.abs(v);
    if (a !== 0 && (a < 1e-3 || a >= 1e6)) return v.toExponential(3);
    return String(Number(v.toPrecision(6)));
  }

  // The marks (the cut-off line) drawn over the plot after the series.
  function drawMarks(marks) {
    return function (u) {
      if (!marks || !marks.length) return;
      var ctx = u.ctx;
      var box = u.bbox;
      var ratio = uPlot.pxRatio || 1;
      ctx.save();
      ctx.strokeStyle = '#444';
      ctx.fillStyle = '#222';
      ctx.lineWidth = ratio;
      ctx.setLineDash([5 * ratio, 4 * ratio]);
      ctx.font = 12 * ratio + 'px sans-serif';
      // A horizontal line's label sits at the left, or at the right when a label at the left
      // is already that close (a speed limit and the share of it allowed).
      var leftLabels = [];
      marks.forEach(function (m) {
        ctx.beginPath();
        if (m.kind === 'vertical_line') {
          var x = u.valToPos(m.x, 'x', true);
          if (x < box.left || x > box.left + box.width) return;
          ctx.moveTo(x, box.top);
          ctx.lineTo(x, box.top + box.height);
          ctx.stroke();
          ctx.fillText(m.label, x + 4 * ratio, box.top + 14 * ratio);
        } else if (m.kind === 'horizontal_line') {
          var y = u.valToPos(m.y, 'y', true);
          if (y < box.top || y > box.top + box.height) return;
          ctx.moveTo(box.left, y);
          ctx.lineTo(box.left + box.width, y);
          ctx.stroke();
          var crowded = leftLabels.some(function (other) { return Math.abs(other - y) < 14 * ratio; });
          if (crowded) {
            ctx.textAlign = 'right';
            ctx.fillText(m.label, box.left + box.width - 4 * ratio, y - 4 * ratio);
            ctx.textAlign = 'left';
          } else {
            leftLabels.push(y);
            ctx.fillText(m.label, box.left + 4 * ratio, y - 4 * ratio);
          }
        }
      });
      ctx.restore();
    };
  }

  function seriesOptions(s) {
    var stroke = colour(s.role);
    var o = { label: s.label, stroke: stroke, width: 1.5, spanGaps: false, value: function (u, v) { return format(v); } };
    if (s.style === 'dashed') o.dash = [6, 4];
    if (s.style === 'points') {
      o.paths = uPlot.paths.points();
      o.points = { show: true, size: 4, width: 1, stroke: stroke, fill: stroke };
    } else {
      o.points = { show: false };
    }
    if (s.style === 'steps') o.paths = uPlot.paths.stepped({ align: 1 });
    return o;
  }

  // Tick values with as many decimals as their spacing needs (a residual of ±0.02 mm reads
  // "-0.02", "0", "0.02", not "0", "0", "0").
  function linearValues(u, splits, axisIdx, space, incr) {
    var step = incr || (splits.length > 1 ? Math.abs(splits[1] - splits[0]) : 1);
    var decimals = step > 0 && isFinite(step) ? Math.max(0, Math.min(12, -Math.floor(Math.log10(step) + 1e-9))) : 0;
    return splits.map(function (v) {
      if (v === null || v === undefined || !isFinite(v)) return '';
      var a = Math.abs(v);
      if (a !== 0 && (a >= 1e6 || step < 1e-6)) return v.toExponential(1);
      var text = v.toFixed(decimals);
      return Number(text) === 0 ? '0' : text;
    });
  }

  // A log axis labels its powers of ten only (1e-5 ... 10), the ticks between unlabelled;
  // Math.log10 of a tick uPlot made from 10^k is k to within rounding.
  function logValues(u, splits) {
    var decade = function (v) { return v > 0 && Math.abs(Math.log10(v) - Math.round(Math.log10(v))) <= 1e-6; };
    // Less than a decade in view: every tick labelled, two significant digits.
    if (splits.filter(decade).length < 2) {
      return splits.map(function (v) { return v > 0 ? String(Number(v.toPrecision(2))) : ''; });
    }
    return splits.map(function (v) {
      if (!(v > 0)) return '';
      var e = Math.log10(v);
      if (Math.abs(e - Math.round(e)) > 1e-6) return '';
      e = Math.round(e);
      if (e >= -3 && e <= 4) return String(Number(Math.pow(10, e).toPrecision(1)));
      return '1e' + e;
    });
  }

  function yAxis(axis, short) {
    var a = { label: axisLabel(axis), size: 70, labelSize: 18, labelFont: '12px sans-serif' };
    if (short) a.space = 22;
    if (axis.ticks && axis.ticks.length) {
      var ticks = axis.ticks;
      a.splits = function () { return ticks.map(function (t) { return t.value; }); };
      a.values = function (u, splits) {
        return splits.map(function (v) {
          var t = ticks.find(function (t) { return t.value === v; });
          return t ? t.label : '';
        });
      };
    } else if (axis.scale === 'log') {
      a.values = logValues;
    } else {
      a.values = linearValues;
    }
    return a;
  }

  function yScale(axis) {
    var s = {};
    if (axis.scale === 'log') s.distr = 3;
    if (axis.range) {
      var r = axis.range;
      s.range = function () { return [r[0], r[1]]; };
    }
    return s;
  }

  // A panel whose series share the panel's x (time, frequency).
  function alignedPlot(panel, width, target) {
    var data = [panel.x].concat(panel.series.map(function (s) { return s.y; }));
    var opts = {
      width: width,
      height: panel.shape.kind === 'short' ? HEIGHTS.short : HEIGHTS.wide,
      scales: { x: { time: false }, y: yScale(panel.y_axis) },
      axes: [{ label: axisLabel(panel.x_axis), labelSize: 18, values: linearValues }, yAxis(panel.y_axis, panel.shape.kind === 'short')],
      series: [{ label: axisLabel(panel.x_axis), value: function (u, v) { return format(v); } }]
        .concat(panel.series.map(seriesOptions)),
      legend: { live: true },
      cursor: { drag: { x: true, y: false } },
      hooks: { draw: [drawMarks(panel.marks)] }
    };
    return new uPlot(opts, data, target);
  }

  // A panel drawn to scale: series with their own x (paths, circles). uPlot's facet mode;
  // the ranges keep one unit as long across as up, at start, after a zoom and after a resize.
  function equalAspectPlot(panel, side, target, readout) {
    var initial = { x: panel.shape.x_range.slice(), y: panel.shape.y_range.slice() };
    var view = { x: initial.x.slice(), y: initial.y.slice() };
    var series = [{}].concat(panel.series.map(function (s) {
      var o = seriesOptions(s);
      o.facets = [{ scale: 'x', auto: false }, { scale: 'y', auto: false }];
      if (s.style !== 'points') o.paths = uPlot.paths.linear();
      return o;
    }));
    var data = [null].concat(panel.series.map(function (s) { return [s.x, s.y]; }));
    // Widens the view's narrower span so that units per pixel are equal on both axes.
    function fit(u, want) {
      var w = u.bbox.width, h = u.bbox.height;
      var per = Math.max((want.x[1] - want.x[0]) / w, (want.y[1] - want.y[0]) / h);
      var cx = (want.x[0] + want.x[1]) / 2, cy = (want.y[0] + want.y[1]) / 2;
      view.x = [cx - per * w / 2, cx + per * w / 2];
      view.y = [cy - per * h / 2, cy + per * h / 2];
      u.batch(function () {
        u.setScale('x', { min: view.x[0], max: view.x[1] });
        u.setScale('y', { min: view.y[0], max: view.y[1] });
      });
    }
    var opts = {
      mode: 2,
      width: side + 70,
      height: side + 50,
      scales: {
        x: { time: false, auto: false, range: function () { return view.x.slice(); } },
        y: { auto: false, range: function () { return view.y.slice(); } }
      },
      axes: [{ label: axisLabel(panel.x_axis), labelSize: 18, values: linearValues }, yAxis(panel.y_axis, false)],
      series: series,
      legend: { live: false },
      cursor: { drag: { x: true, y: true, uni: 20, setScale: false }, points: { show: false } },
      hooks: {
        ready: [function (u) {
          fit(u, initial);
          u.over.addEventListener('dblclick', function () { fit(u, initial); });
        }],
        setSelect: [function (u) {
          var s = u.select;
          if (s.width < 4 || s.height < 4) return;
          var want = {
            x: [u.posToVal(s.left, 'x'), u.posToVal(s.left + s.width, 'x')],
            y: [u.posToVal(s.top + s.height, 'y'), u.posToVal(s.top, 'y')]
          };
          u.setSelect({ left: 0, top: 0, width: 0, height: 0 }, false);
          fit(u, want);
        }],
        setCursor: [function (u) {
          var c = u.cursor;
          if (c.left == null || c.left < 0) { readout.textContent = ''; return; }
          readout.textContent = panel.x_axis.label + ' = ' + format(u.posToVal(c.left, 'x')) + ' ' +
            panel.x_axis.unit + ', ' + panel.y_axis.label + ' = ' + format(u.posToVal(c.top, 'y')) +
            ' ' + panel.y_axis.unit;
        }],
        draw: [drawMarks(panel.marks)]
      }
    };
    var plot = new uPlot(opts, data, target);
    plot.teachcamFit = function () { fit(plot, { x: view.x.slice(), y: view.y.slice() }); };
    return plot;
  }

  function widthOf(container) {
    var w = container.clientWidth || (container.getBoundingClientRect && container.getBoundingClientRect().width) || 0;
    return Math.max(320, Math.floor(w || 900) - 10);
  }

  function draw(container, figures) {
    ensureStyle();
    if (container.teachcamPlots) {
      container.teachcamPlots.forEach(function (p) { p.destroy(); });
    }
    if (container.teachcamObserver) container.teachcamObserver.disconnect();
    container.teachcamPlots = [];
    container.replaceChildren();
    var width = widthOf(container);
    var aligned = [];
    (figures || []).forEach(function (figure) {
      var section = element('section', 'tc-figure');
      section.setAttribute('data-figure', figure.id);
      section.setAttribute('data-kind', figure.kind);
      section.appendChild(element('h2', null, figure.title));
      container.appendChild(section);
      if (figure.kind === 'missing') {
        section.appendChild(element('p', 'tc-missing', 'Missing: ' + figure.reason));
      } else if (figure.kind === 'images') {
        var strip = element('div', 'tc-images');
        figure.images.forEach(function (image) {
          var f = element('figure');
          var img = element('img');
          img.alt = image.label;
          img.width = image.width_px;
          img.height = image.height_px;
          img.src = 'data:image/png;base64,' + image.png_base64;
          f.appendChild(img);
          f.appendChild(element('figcaption', null, image.label));
          strip.appendChild(f);
        });
        section.appendChild(strip);
      } else {
        // Panels drawn to scale sit side by side, as many as fit at 240 px or more.
        var scaled = figure.panels.filter(function (p) { return p.shape.kind === 'equal_aspect'; }).length;
        var across = Math.max(1, Math.min(scaled, Math.floor(width / 320)));
        var side = Math.max(160, Math.min(560, Math.floor((width - 12 * (across - 1)) / across) - 80));
        var row = null;
        figure.panels.forEach(function (panel) {
          var box = element('div', 'tc-panel');
          box.setAttribute('data-shape', panel.shape.kind);
          box.appendChild(element('div', 'tc-panel-title', panel.title));
          var plot;
          if (panel.shape.kind === 'equal_aspect') {
            if (!row) {
              row = element('div', 'tc-row');
              section.appendChild(row);
            }
            row.appendChild(box);
            var readout = element('div', 'tc-readout');
            plot = equalAspectPlot(panel, side, box, readout);
            box.appendChild(readout);
          } else {
            row = null;
            section.appendChild(box);
            plot = alignedPlot(panel, width, box);
            aligned.push(plot);
          }
          container.teachcamPlots.push(plot);
        });
      }
      if (figure.caption) section.appendChild(element('p', 'tc-caption', figure.caption));
    });
    if (window.ResizeObserver) {
      var last = width;
      container.teachcamObserver = new ResizeObserver(function () {
        var w = widthOf(container);
        if (Math.abs(w - last) < 8) return;
        last = w;
        aligned.forEach(function (p) { p.setSize({ width: w, height: p.height }); });
      });
      container.teachcamObserver.observe(container);
    }
    return container.teachcamPlots.length;
  }

  window.teachcamReview = { draw: draw };
})();
