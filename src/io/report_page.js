// moa report page: draws the charts from the JSON in #moa-data with Chart.js.
//
// Zoom: drag a box on a chart, double-click to reset. The time charts zoom
// together. The x-y charts keep one metre the same length on both axes.
// When done, each canvas carries data-painted ("1" when anything is drawn
// on it) and data-points (data elements drawn), and the body carries
// data-moa-status="ready": the browser test reads them.
(function () {
  'use strict';

  var data = JSON.parse(document.getElementById('moa-data').textContent);
  var palette = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2',
                 '#7f7f7f', '#bcbd22', '#17becf', '#393b79', '#637939', '#8c6d31', '#843c39',
                 '#7b4173', '#3182bd'];
  var charts = [];
  var timeCharts = [];

  Chart.defaults.animation = false;
  Chart.defaults.maintainAspectRatio = false;
  Chart.defaults.font.family = 'system-ui, -apple-system, "Segoe UI", Roboto, sans-serif';
  Chart.defaults.font.size = 12;
  Chart.defaults.plugins.legend.labels.boxWidth = 14;

  function num(x, digits) {
    return x === null || x === undefined ? '-' : Number(x).toPrecision(digits || 4);
  }
  function sensorColor(i) { return palette[i % palette.length]; }
  function points(xs, ys, ts) {
    var out = new Array(xs.length);
    for (var k = 0; k < xs.length; ++k) out[k] = {x: xs[k], y: ys[k], t: ts ? ts[k] : undefined};
    return out;
  }
  function gap() { return {x: null, y: null}; }
  function reportError(where, e) {
    var text = where + ': ' + (e && e.message ? e.message : String(e));
    window.moaErrors.push(text);
    var box = document.getElementById('moa-errors');
    box.textContent = window.moaErrors.join('\n');
    box.hidden = false;
  }

  // Names of the points that carry one (`name`), drawn beside them.
  var labelPlugin = {
    id: 'moaLabels',
    afterDatasetsDraw: function (chart) {
      var ctx = chart.ctx;
      ctx.save();
      ctx.font = '12px ' + Chart.defaults.font.family;
      ctx.fillStyle = '#222';
      chart.data.datasets.forEach(function (ds, i) {
        if (!ds.moaLabels || !chart.isDatasetVisible(i)) return;
        chart.getDatasetMeta(i).data.forEach(function (el, k) {
          var name = ds.data[k] && ds.data[k].name;
          if (name) ctx.fillText(name, el.x + 7, el.y - 7);
        });
      });
      ctx.restore();
    }
  };

  // x-y charts: the limits widened on one axis so that a metre is as long
  // on x as on y.
  function equalise(chart, lim) {
    chart.$limits = lim;
    for (var pass = 0; pass < 2; ++pass) {  // the axes' labels may move the area once
      var a = chart.chartArea;
      var w = a.right - a.left, h = a.bottom - a.top;
      var cx = (lim.x[0] + lim.x[1]) / 2, cy = (lim.y[0] + lim.y[1]) / 2;
      var s = Math.max((lim.x[1] - lim.x[0]) / w, (lim.y[1] - lim.y[0]) / h);
      if (!(s > 0) || !isFinite(s)) s = 1e-3;
      var sx = chart.options.scales.x, sy = chart.options.scales.y;
      sx.min = cx - s * w / 2;
      sx.max = cx + s * w / 2;
      sy.min = cy - s * h / 2;
      sy.max = cy + s * h / 2;
      chart.update('none');
    }
  }

  function bounds(datasets, margin) {
    var x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    datasets.forEach(function (ds) {
      ds.data.forEach(function (p) {
        if (p.x === null || p.y === null) return;
        x0 = Math.min(x0, p.x); x1 = Math.max(x1, p.x);
        y0 = Math.min(y0, p.y); y1 = Math.max(y1, p.y);
      });
    });
    if (!isFinite(x0)) return {x: [-1, 1], y: [-1, 1]};
    var m = Math.max(x1 - x0, y1 - y0) * margin + 1e-3;
    return {x: [x0 - m, x1 + m], y: [y0 - m, y1 + m]};
  }

  function setTimeRange(range) {
    timeCharts.forEach(function (chart) {
      chart.options.scales.x.min = range[0];
      chart.options.scales.x.max = range[1];
      chart.update('none');
    });
  }

  // Box zoom: kind 'xy' zooms both axes (equal scale), 'x' the time axis of
  // every time chart.
  function attachZoom(chart, kind) {
    var canvas = chart.canvas;
    var box = document.createElement('div');
    box.className = 'zoombox';
    canvas.parentNode.appendChild(box);
    var start = null;
    function at(e) {
      var r = canvas.getBoundingClientRect();
      return {x: e.clientX - r.left, y: e.clientY - r.top};
    }
    function inside(p) {
      var a = chart.chartArea;
      return p.x >= a.left && p.x <= a.right && p.y >= a.top && p.y <= a.bottom;
    }
    function corners(p) {
      var a = chart.chartArea;
      var x0 = Math.max(a.left, Math.min(start.x, p.x)), x1 = Math.min(a.right, Math.max(start.x, p.x));
      var y0 = kind === 'x' ? a.top : Math.max(a.top, Math.min(start.y, p.y));
      var y1 = kind === 'x' ? a.bottom : Math.min(a.bottom, Math.max(start.y, p.y));
      return {x0: x0, x1: x1, y0: y0, y1: y1};
    }
    canvas.addEventListener('mousedown', function (e) {
      var p = at(e);
      if (e.button === 0 && inside(p)) start = p;
    });
    window.addEventListener('mousemove', function (e) {
      if (!start) return;
      var c = corners(at(e));
      box.style.left = c.x0 + 'px';
      box.style.top = c.y0 + 'px';
      box.style.width = (c.x1 - c.x0) + 'px';
      box.style.height = (c.y1 - c.y0) + 'px';
      box.style.display = 'block';
    });
    window.addEventListener('mouseup', function (e) {
      if (!start) return;
      var c = corners(at(e));
      start = null;
      box.style.display = 'none';
      if (c.x1 - c.x0 < 5 || (kind === 'xy' && c.y1 - c.y0 < 5)) return;
      var sx = chart.scales.x, sy = chart.scales.y;
      var xr = [sx.getValueForPixel(c.x0), sx.getValueForPixel(c.x1)];
      if (kind === 'x') {
        setTimeRange(xr);
      } else {
        equalise(chart, {x: xr, y: [sy.getValueForPixel(c.y1), sy.getValueForPixel(c.y0)]});
      }
    });
    canvas.addEventListener('dblclick', function () {
      if (kind === 'x') {
        setTimeRange([data.t0, data.t1]);
      } else {
        equalise(chart, chart.$home);
      }
    });
  }

  function xyChart(id, datasets, title) {
    var chart = new Chart(document.getElementById(id), {
      type: 'scatter',
      data: {datasets: datasets},
      plugins: [labelPlugin],
      options: {
        interaction: {mode: 'nearest', intersect: false, axis: 'xy'},
        scales: {
          x: {type: 'linear', title: {display: true, text: title[0]}, ticks: {includeBounds: false}},
          y: {type: 'linear', title: {display: true, text: title[1]}, ticks: {includeBounds: false}}
        },
        plugins: {
          tooltip: {
            filter: function (item) { return !item.dataset.moaQuiet && item.raw && item.raw.x !== null; },
            callbacks: {
              label: function (ctx) {
                var r = ctx.raw;
                var s = (r.name ? r.name + ' ' : '') + ctx.dataset.label + ': (' + num(r.x) + ', ' +
                        num(r.y) + ') m';
                if (r.t !== undefined) s += ', t ' + num(r.t, 6) + ' s';
                if (r.note) s += ', ' + r.note;
                return s;
              }
            }
          }
        },
        onResize: function (c) {
          if (c.$limits) window.setTimeout(function () { equalise(c, c.$limits); }, 0);
        }
      }
    });
    chart.$home = bounds(datasets.filter(function (ds) { return !ds.moaQuiet || ds.moaBounds; }), 0.05);
    equalise(chart, chart.$home);
    attachZoom(chart, 'xy');
    charts.push(chart);
    return chart;
  }

  function timeChart(id, datasets, yAxes, extra) {
    var scales = {x: {type: 'linear', min: data.t0, max: data.t1,
                      title: {display: true, text: 'time (s)'}, ticks: {includeBounds: false}}};
    Object.keys(yAxes).forEach(function (k) { scales[k] = yAxes[k]; });
    var options = {
      interaction: {mode: 'nearest', intersect: false, axis: 'x'},
      scales: scales,
      plugins: {tooltip: {filter: function (item) { return item.raw && item.raw.y !== null; }}}
    };
    Object.keys(extra || {}).forEach(function (k) { options[k] = extra[k]; });
    var chart = new Chart(document.getElementById(id),
                          {type: 'line', data: {datasets: datasets}, options: options});
    attachZoom(chart, 'x');
    timeCharts.push(chart);
    charts.push(chart);
    return chart;
  }

  // Sensors on the robot at pose (x, y, theta): world-frame points.
  function robotShape(mounts, pose, radius) {
    var c = Math.cos(pose.theta), s = Math.sin(pose.theta);
    function world(px, py) { return {x: pose.x + c * px - s * py, y: pose.y + s * px + c * py}; }
    var outline = [];
    for (var k = 0; k <= 36; ++k) {
      var a = 2 * Math.PI * k / 36;
      outline.push(world(radius * Math.cos(a), radius * Math.sin(a)));
    }
    outline.push(gap(), world(0, 0), world(radius, 0), gap());
    var sensors = mounts.map(function (m, i) {
      var p = world(m.x, m.y);
      p.name = m.name;
      p.t = pose.t;
      p.color = sensorColor(i);
      return p;
    });
    return {outline: outline, sensors: sensors};
  }

  function robotRadius(mounts) {
    var r = 0;
    mounts.forEach(function (m) { r = Math.max(r, Math.hypot(m.x, m.y)); });
    return r > 0 ? 1.25 * r : 0.05;
  }

  function drawTrajectory() {
    var b = data.bins;
    var datasets = [{
      label: 'estimate', data: points(b.x, b.y, b.t), showLine: true, pointRadius: 0,
      borderColor: '#1565c0', backgroundColor: '#1565c0', borderWidth: 1.8
    }];
    if (data.truth) {
      datasets.push({label: 'truth', data: points(data.truth.x, data.truth.y, data.truth.t),
                     showLine: true, pointRadius: 0, borderColor: '#222', backgroundColor: '#222',
                     borderWidth: 1.2, borderDash: [6, 4]});
    }
    if (data.camera) {
      datasets.push({label: 'camera fixes', data: points(data.camera.x, data.camera.y),
                     pointRadius: 2.5, borderColor: '#8e44ad', backgroundColor: '#8e44ad'});
    }
    var n = b.t.length, radius = robotRadius(data.sensors);
    var outline = [], sensors = [];
    var shown = Math.min(n, 8);
    for (var k = 0; k < shown; ++k) {
      var i = shown === 1 ? 0 : Math.round(k * (n - 1) / (shown - 1));
      var shape = robotShape(data.sensors, {x: b.x[i], y: b.y[i], theta: b.theta[i], t: b.t[i]}, radius);
      outline = outline.concat(shape.outline);
      sensors = sensors.concat(shape.sensors);
    }
    datasets.push({label: 'robot', data: outline, showLine: true, pointRadius: 0, spanGaps: false,
                   borderColor: '#888', backgroundColor: '#888', borderWidth: 1, moaQuiet: true,
                   moaBounds: true});
    datasets.push({label: 'sensors', data: sensors, pointRadius: 3,
                   pointBackgroundColor: sensors.map(function (p) { return p.color; }),
                   pointBorderColor: sensors.map(function (p) { return p.color; }),
                   borderColor: '#666', backgroundColor: '#666'});
    datasets.push({label: 'start', data: [points(b.x, b.y, b.t)[0]], pointRadius: 6,
                   pointStyle: 'triangle', borderColor: '#2ca02c', backgroundColor: '#2ca02c'});
    datasets.push({label: 'end', data: [points(b.x, b.y, b.t)[n - 1]], pointRadius: 6,
                   pointStyle: 'rectRot', borderColor: '#d62728', backgroundColor: '#d62728'});
    xyChart('chart-trajectory', datasets, ['x (m)', 'y (m)']);
  }

  function drawErrors() {
    if (!data.errors) return;
    var t = data.bins.t;
    timeChart('chart-errors', [
      {label: 'translation error (m)', data: points(t, data.errors.translation), yAxisID: 'y',
       pointRadius: 0, borderWidth: 1.5, borderColor: '#1f77b4', backgroundColor: '#1f77b4',
       spanGaps: false},
      {label: 'heading error (rad)', data: points(t, data.errors.heading), yAxisID: 'y1',
       pointRadius: 0, borderWidth: 1.5, borderColor: '#ff7f0e', backgroundColor: '#ff7f0e',
       spanGaps: false}
    ], {
      y: {type: 'linear', position: 'left', beginAtZero: true, title: {display: true, text: 'translation error (m)'}},
      y1: {type: 'linear', position: 'right', beginAtZero: true, grid: {drawOnChartArea: false},
           title: {display: true, text: 'heading error (rad)'}}
    });
  }

  var stateColors = {
    used: '#2ca02c', mice: '#1f77b4', wheels: '#ff7f0e', hold: '#d62728', absent: '#cccccc',
    inconsistent: '#d62728', unreliable: '#9467bd', lift: '#8c564b', fallback: '#7f7f7f'
  };
  function stateColor(name, k) {
    var base = name.split('/')[0];
    var color = stateColors[base] || palette[(k + 4) % palette.length];
    if (name.indexOf('/') >= 0) color += 'aa';  // a flagged variant: lighter
    return color;
  }

  function drawTimeline() {
    var tl = data.timeline;
    if (!tl) return;
    var byState = {};
    tl.segments.forEach(function (s) {
      (byState[s[1]] = byState[s[1]] || []).push({y: tl.rows[s[0]], x: [s[2], s[3]], share: s[4]});
    });
    var datasets = Object.keys(byState).map(Number).sort(function (a, b) { return a - b; }).map(function (k) {
      var c = stateColor(tl.states[k], k);
      return {label: tl.states[k], data: byState[k], backgroundColor: c, borderColor: c,
              borderWidth: 0, grouped: false, barPercentage: 0.75, categoryPercentage: 1.0,
              borderSkipped: false};
    });
    var chart = new Chart(document.getElementById('chart-timeline'), {
      type: 'bar',
      data: {labels: tl.rows, datasets: datasets},
      options: {
        indexAxis: 'y',
        interaction: {mode: 'nearest', intersect: true},
        scales: {
          x: {type: 'linear', min: data.t0, max: data.t1, title: {display: true, text: 'time (s)'},
              ticks: {includeBounds: false}},
          y: {type: 'category', labels: tl.rows, offset: true, grid: {offset: true}}
        },
        plugins: {
          tooltip: {
            callbacks: {
              label: function (ctx) {
                var r = ctx.raw;
                return r.y + ' ' + ctx.dataset.label + ': ' + num(r.x[0], 6) + ' s to ' +
                       num(r.x[1], 6) + ' s (' + Math.round(100 * r.share) + '% of its epochs)';
              }
            }
          }
        }
      }
    });
    attachZoom(chart, 'x');
    timeCharts.push(chart);
    charts.push(chart);
  }

  function drawSpeed() {
    var t = data.bins.t;
    var datasets = data.sensors.map(function (m, i) {
      return {label: m.name, data: points(t, data.speed[i]), pointRadius: 0, borderWidth: 1.3,
              borderColor: sensorColor(i), backgroundColor: sensorColor(i)};
    });
    var groups = {};
    data.sensors.forEach(function (m, i) {
      if (m.max_speed === null) return;
      (groups[m.max_speed] = groups[m.max_speed] || []).push(i);
    });
    var keys = Object.keys(groups);
    keys.forEach(function (key) {
      var members = groups[key];
      var all = keys.length === 1 && members.length === data.sensors.length;
      var color = all ? '#d62728' : sensorColor(members[0]);
      var v = Number(key);
      datasets.push({
        label: 'rated max_speed ' + num(v) + ' m/s' + (all ? '' : ' (' + members.map(function (i) {
          return data.sensors[i].name; }).join(', ') + ')'),
        data: [{x: data.t0, y: v}, {x: data.t1, y: v}], pointRadius: 0, borderWidth: 1.5,
        borderDash: [8, 5], borderColor: color, backgroundColor: color
      });
    });
    timeChart('chart-speed', datasets,
              {y: {type: 'linear', beginAtZero: true, title: {display: true, text: 'point speed (m/s)'}}});
  }

  // `drawn` holds the positions and yaws to draw (calibrated ones magnified);
  // the tooltips give the mounts' own values.
  function mountShapes(mounts, drawn, label, length, hollow, dash) {
    var axes = [];
    var pts = mounts.map(function (m, i) {
      var d = drawn[i];
      axes.push({x: d.x, y: d.y}, {x: d.x + length * Math.cos(d.yaw), y: d.y + length * Math.sin(d.yaw)}, gap());
      return {x: d.x, y: d.y, name: m.name, color: sensorColor(i),
              note: 'mount (' + num(m.x, 5) + ', ' + num(m.y, 5) + ') m, yaw ' + num(m.yaw, 5) + ' rad' +
                    (m.mirrored ? ', mirrored' : '') +
                    (m.max_speed !== null ? ', max_speed ' + num(m.max_speed) + ' m/s' : '')};
    });
    var colors = pts.map(function (p) { return p.color; });
    return [
      {label: label, data: pts, pointRadius: hollow ? 7 : 4, pointBorderWidth: 2, moaLabels: !dash,
       pointBorderColor: colors, pointBackgroundColor: hollow ? 'rgba(0,0,0,0)' : colors,
       borderColor: '#444', backgroundColor: hollow ? 'rgba(0,0,0,0)' : '#444'},
      {label: label.split(' (')[0] + ' x axes', data: axes, showLine: true, pointRadius: 0, spanGaps: false,
       borderColor: dash ? '#d62728' : '#444', backgroundColor: dash ? '#d62728' : '#444',
       borderWidth: 1.5, borderDash: dash || [], moaQuiet: true, moaBounds: true}
    ];
  }

  // The largest of 1, 2, 5 times a power of ten not above x (at least 1).
  function niceGain(x) {
    if (!(x > 1) || !isFinite(x)) return 1;
    var p = Math.pow(10, Math.floor(Math.log10(x)));
    return x >= 5 * p ? 5 * p : x >= 2 * p ? 2 * p : p;
  }
  function wrap(a) { return Math.atan2(Math.sin(a), Math.cos(a)); }

  function drawLayout() {
    var radius = robotRadius(data.sensors);
    var outline = robotShape([], {x: 0, y: 0, theta: 0}, radius).outline;
    var length = 0.35 * radius;
    var datasets = [{label: 'robot outline and x axis', data: outline, showLine: true, pointRadius: 0,
                     spanGaps: false, borderColor: '#aaa', backgroundColor: '#aaa', borderWidth: 1,
                     moaQuiet: true, moaBounds: true}];
    datasets = datasets.concat(mountShapes(data.sensors, data.sensors,
                                           data.calibrated ? 'nominal' : 'sensors', length,
                                           !!data.calibrated, null));
    var cal = data.calibrated;
    if (cal) {
      // Calibration moves mounts by millimetres: the changes are drawn
      // magnified (largest shift 15% of the robot's radius, largest yaw change 10 deg).
      var maxShift = 0, maxYaw = 0;
      data.sensors.forEach(function (m, i) {
        maxShift = Math.max(maxShift, Math.hypot(cal[i].x - m.x, cal[i].y - m.y));
        maxYaw = Math.max(maxYaw, Math.abs(wrap(cal[i].yaw - m.yaw)));
      });
      var shiftGain = niceGain(0.15 * radius / maxShift), yawGain = niceGain(0.1745 / maxYaw);
      var drawn = data.sensors.map(function (m, i) {
        return {x: m.x + shiftGain * (cal[i].x - m.x), y: m.y + shiftGain * (cal[i].y - m.y),
                yaw: m.yaw + yawGain * wrap(cal[i].yaw - m.yaw)};
      });
      var gains = [];
      if (shiftGain > 1) gains.push('shifts x' + shiftGain);
      if (yawGain > 1) gains.push('yaw changes x' + yawGain);
      var label = 'calibrated' + (gains.length ? ' (' + gains.join(', ') + ')' : '');
      datasets = datasets.concat(mountShapes(cal, drawn, label, length, false, [5, 3]));
      var shifts = [];
      data.sensors.forEach(function (m, i) { shifts.push({x: m.x, y: m.y}, drawn[i], gap()); });
      datasets.push({label: 'shift', data: shifts, showLine: true, pointRadius: 0, spanGaps: false,
                     borderColor: '#d62728', backgroundColor: '#d62728', borderWidth: 2, moaQuiet: true});
    }
    xyChart('chart-layout', datasets, ['x (m), robot frame', 'y (m), robot frame']);
  }

  function painted(canvas) {
    var d = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    for (var k = 3; k < d.length; k += 4) {
      if (d[k] !== 0) return true;
    }
    return false;
  }

  [['trajectory', drawTrajectory], ['errors', drawErrors], ['timeline', drawTimeline],
   ['speed', drawSpeed], ['layout', drawLayout]].forEach(function (step) {
    try {
      step[1]();
    } catch (e) {
      reportError(step[0], e);
    }
  });

  window.setTimeout(function () {
    charts.forEach(function (chart) {
      var elements = 0;
      chart.data.datasets.forEach(function (ds, i) {
        if (chart.isDatasetVisible(i)) elements += chart.getDatasetMeta(i).data.length;
      });
      chart.canvas.setAttribute('data-points', String(elements));
      chart.canvas.setAttribute('data-painted', painted(chart.canvas) ? '1' : '0');
    });
    document.body.setAttribute('data-moa-status', 'ready');
  }, 0);
})();
