// The live dashboard's script: reads the robot from #moa-config, listens to
// /events (Server-Sent Events, one JSON object per event) and redraws the
// trajectory with the robot and its sensors, per-sensor health and the
// twist over the last seconds, the run's warnings. Chart.js 3 is inlined
// before this script. A client that joins late gets the trajectory, the
// twist and the warnings so far ("event: history", "event: warning").
// For tests: <body data-moa-status> is loading | live | ended, each canvas
// carries data-updates (times redrawn) and data-points, <body data-events>
// the events received, #warnings one <li> per warning, #heading-source the
// heading source and the gyro's calibration (with a gyro); errors go to
// #moa-errors (not the console).
(function () {
  'use strict';
  const config = JSON.parse(document.getElementById('moa-config').textContent);
  const body = document.body;
  const errors = document.getElementById('moa-errors');
  function fail(text) {
    errors.hidden = false;
    errors.textContent += text + '\n';
  }
  window.addEventListener('error', function (e) { fail(String(e.message)); });

  const colours = ['#1e88e5', '#e53935', '#43a047', '#fb8c00', '#8e24aa', '#00acc1', '#6d4c41',
                   '#3949ab'];
  const colour = (i) => colours[i % colours.length];
  const sensors = config.sensors;
  const window_s = 10;        // twist plot: the last seconds
  const max_path = 20000;     // trajectory points drawn
  const reach = Math.max(0.05, ...sensors.map((s) => Math.hypot(s.x, s.y))) * 1.3;

  Chart.defaults.animation = false;
  Chart.defaults.maintainAspectRatio = false;
  Chart.defaults.plugins.legend.labels.boxWidth = 12;

  function counted(chart) {
    const canvas = chart.canvas;
    let points = 0;
    for (const d of chart.data.datasets) points += d.data.length;
    canvas.dataset.points = String(points);
    canvas.dataset.updates = String(Number(canvas.dataset.updates || 0) + 1);
  }

  // ------------------------------------------------------------- trajectory
  const path = [];
  const trajectory = new Chart(document.getElementById('chart-trajectory'), {
    type: 'scatter',
    data: {
      datasets: [
        { label: 'path', data: path, showLine: true, pointRadius: 0, borderColor: '#546e7a',
          borderWidth: 1.5 },
        { label: 'robot', data: [], showLine: true, pointRadius: 0, borderColor: '#263238',
          borderWidth: 2 },
        { label: 'sensors', data: [], pointRadius: 5, pointBackgroundColor: [],
          pointBorderColor: [], showLine: false },
      ],
    },
    options: {
      parsing: false,
      normalized: true,
      scales: { x: { type: 'linear', title: { display: true, text: 'x (m)' } },
                y: { type: 'linear', title: { display: true, text: 'y (m)' } } },
      plugins: { legend: { display: false } },
    },
  });

  // Equal scales on both axes, the whole path and the robot in view.
  function fit_axes(chart, points) {
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    for (const p of points) {
      x0 = Math.min(x0, p.x); x1 = Math.max(x1, p.x);
      y0 = Math.min(y0, p.y); y1 = Math.max(y1, p.y);
    }
    if (!isFinite(x0)) { x0 = -reach; x1 = reach; y0 = -reach; y1 = reach; }
    const area = chart.chartArea || { width: 1, height: 1 };
    const aspect = area.width > 0 && area.height > 0 ? area.width / area.height : 1;
    let w = Math.max(x1 - x0, 2 * reach) * 1.1, h = Math.max(y1 - y0, 2 * reach) * 1.1;
    if (w / h < aspect) w = h * aspect; else h = w / aspect;
    const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    chart.options.scales.x.min = cx - w / 2; chart.options.scales.x.max = cx + w / 2;
    chart.options.scales.y.min = cy - h / 2; chart.options.scales.y.max = cy + h / 2;
  }

  function draw_robot(e) {
    const c = Math.cos(e.theta), s = Math.sin(e.theta);
    const world = (px, py) => ({ x: e.x + c * px - s * py, y: e.y + s * px + c * py });
    const outline = [];
    for (let k = 0; k <= 24; ++k) {
      const a = (2 * Math.PI * k) / 24;
      outline.push(world(reach * Math.cos(a), reach * Math.sin(a)));
    }
    outline.push(world(0, 0), world(reach, 0));  // heading
    trajectory.data.datasets[1].data = outline;
    const dots = trajectory.data.datasets[2];
    dots.data = sensors.map((m) => world(m.x, m.y));
    dots.pointBackgroundColor = e.sensors.map((m, i) => (m.used ? colour(i) : '#ffffff'));
    dots.pointBorderColor = e.sensors.map((m, i) => colour(i));
    fit_axes(trajectory, path.concat(outline));
    trajectory.update('none');
    counted(trajectory);
  }

  // ----------------------------------------------------------------- health
  const health = new Chart(document.getElementById('chart-health'), {
    type: 'bar',
    data: {
      labels: sensors.map((s) => s.name),
      datasets: [
        { label: 'used (share of epochs, last 10 s)', data: sensors.map(() => 0),
          backgroundColor: sensors.map((s, i) => colour(i)), xAxisID: 'x' },
        { label: 'SQUAL / 255', data: sensors.map(() => 0), backgroundColor: '#b0bec5',
          xAxisID: 'x' },
      ],
    },
    options: {
      indexAxis: 'y',
      scales: { x: { min: 0, max: 1 } },
    },
  });

  const table = document.querySelector('#sensor-table tbody');
  const rows = sensors.map((s, i) => {
    const tr = document.createElement('tr');
    for (let k = 0; k < 6; ++k) tr.appendChild(document.createElement('td'));
    tr.cells[0].textContent = s.name;
    tr.cells[0].style.color = colour(i);
    table.appendChild(tr);
    return tr;
  });

  // Each sensor's share of the epochs it was used in over the last window_s
  // seconds (an event carries its own few epochs' share).
  const used_log = [];  // {t, epochs, used: [epochs used, per sensor]}
  function used_shares(e) {
    used_log.push({ t: e.t, epochs: e.epochs,
                    used: e.sensors.map((m) => m.used_share * e.epochs) });
    while (used_log.length > 0 && used_log[0].t <= e.t - window_s) used_log.shift();
    let epochs = 0;
    const used = sensors.map(() => 0);
    for (const u of used_log) {
      epochs += u.epochs;
      u.used.forEach((n, i) => { used[i] += n; });
    }
    return used.map((n) => (epochs > 0 ? n / epochs : 0));
  }

  function draw_health(e) {
    const shares = used_shares(e);
    health.data.datasets[0].data = shares;
    health.data.datasets[1].data = e.sensors.map((m) => (m.squal === null ? 0 : m.squal / 255));
    health.update('none');
    counted(health);
    e.sensors.forEach((m, i) => {
      const cells = rows[i].cells;
      cells[1].textContent = m.dx.toFixed(0);
      cells[2].textContent = m.dy.toFixed(0);
      cells[3].textContent = m.squal === null ? '-' : String(m.squal);
      cells[4].textContent = (100 * shares[i]).toFixed(0) + ' %';
      cells[5].textContent = m.excluded === null ? '' : m.excluded;
      rows[i].className = m.used ? '' : 'excluded';
    });
  }

  // ------------------------------------------------------------------ twist
  const twist_sets = [['vx (m/s)', 'vx', '#1e88e5', 'v'], ['vy (m/s)', 'vy', '#43a047', 'v'],
                      ['omega (rad/s)', 'omega', '#e53935', 'w']];
  const twist = new Chart(document.getElementById('chart-twist'), {
    type: 'line',
    data: {
      datasets: twist_sets.map(([label, , c, axis]) => ({
        label: label, data: [], borderColor: c, backgroundColor: c, pointRadius: 0,
        borderWidth: 1.5, yAxisID: axis })),
    },
    options: {
      parsing: false,
      normalized: true,
      scales: {
        x: { type: 'linear', title: { display: true, text: 't (s)' } },
        v: { type: 'linear', position: 'left', title: { display: true, text: 'm/s' } },
        w: { type: 'linear', position: 'right', title: { display: true, text: 'rad/s' },
             grid: { drawOnChartArea: false } },
      },
    },
  });

  function add_twist(t, values) {
    twist_sets.forEach(([, key], k) => {
      const data = twist.data.datasets[k].data;
      data.push({ x: t, y: values[key] });
      while (data.length > 0 && data[0].x < t - window_s) data.shift();
    });
  }

  function draw_twist(e) {
    add_twist(e.t, e);
    twist.options.scales.x.min = e.t - window_s;
    twist.options.scales.x.max = e.t;
    twist.update('none');
    counted(twist);
  }

  // ---------------------------------------------------------------- heading
  // The share of the last window_s seconds' epochs whose heading was the
  // gyro's (e.heading_gyro of e.epochs), and the gyro's calibration now.
  const heading_text = document.getElementById('heading-source');
  const heading_log = [];  // {t, epochs, gyro: epochs with the gyro's heading}
  function draw_heading(e) {
    heading_log.push({ t: e.t, epochs: e.epochs, gyro: e.heading_gyro });
    while (heading_log.length > 0 && heading_log[0].t <= e.t - window_s) heading_log.shift();
    let epochs = 0;
    let gyro = 0;
    for (const h of heading_log) {
      epochs += h.epochs;
      gyro += h.gyro;
    }
    let text = 'heading: ' + e.heading;
    if (e.gyro !== undefined || gyro > 0) {
      text += '   gyro ' + (epochs > 0 ? (100 * gyro) / epochs : 0).toFixed(0) +
        ' % (last ' + window_s + ' s)';
    }
    if (e.gyro !== undefined) {
      const g = e.gyro;
      text += '   bias ' + g.bias.toFixed(5) + ' rad/s (sd ' + g.bias_sd.toFixed(5) +
        ')   scale ' + g.scale.toFixed(4) + ' (sd ' + g.scale_sd.toFixed(4) + ')   test ' +
        (g.test === null ? '-' : g.test.toFixed(2));
    }
    heading_text.textContent = text;
  }

  // ----------------------------------------------------------------- stream
  const status = document.getElementById('status');
  let events = 0;
  const arrivals = [];
  function show_status(e, state) {
    const now = performance.now();
    arrivals.push(now);
    while (arrivals.length > 0 && arrivals[0] < now - 3000) arrivals.shift();
    const span = now - arrivals[0];
    const rate = span >= 500 ? (1000 * (arrivals.length - 1)) / span : null;
    // The heading wrapped into (-180, 180] deg: the pose's theta accumulates turns.
    const heading = (Math.atan2(Math.sin(e.theta), Math.cos(e.theta)) * 180) / Math.PI;
    status.textContent = 't ' + e.t.toFixed(2) + ' s   x ' + e.x.toFixed(3) + ' m   y ' +
      e.y.toFixed(3) + ' m   theta ' + heading.toFixed(1) + ' deg   ' +
      'twist from ' + e.source + '   ' + (rate === null ? '-' : rate.toFixed(1)) + ' events/s   ' +
      state;
  }

  function on_event(e) {
    ++events;
    body.dataset.events = String(events);
    if (path.length >= max_path) path.splice(0, path.length / 2);
    path.push({ x: e.x, y: e.y });
    draw_robot(e);
    draw_health(e);
    draw_twist(e);
    draw_heading(e);
    show_status(e, 'live');
  }

  const source = new EventSource('events');
  body.dataset.events = '0';
  source.addEventListener('history', (m) => {
    const points = JSON.parse(m.data).points;
    for (const [, x, y] of points) path.push({ x: x, y: y });
    const last = points.length > 0 ? points[points.length - 1][0] : 0;
    for (const [t, , , vx, vy, omega] of points) {
      if (t > last - window_s) add_twist(t, { vx: vx, vy: vy, omega: omega });
    }
    body.dataset.moaStatus = 'live';
  });
  const warnings = document.getElementById('warnings');
  let warned = 0;
  source.addEventListener('warning', (m) => {
    if (warned++ === 0) warnings.textContent = '';
    const li = document.createElement('li');
    li.textContent = JSON.parse(m.data).text;
    warnings.appendChild(li);
  });
  source.onmessage = (m) => {
    try {
      on_event(JSON.parse(m.data));
    } catch (err) {
      fail('event: ' + err);
    }
  };
  source.addEventListener('end', (m) => {
    source.close();
    body.dataset.moaStatus = 'ended';
    const t = JSON.parse(m.data).t;
    status.textContent = status.textContent.replace(/ live$/, '') + '   the run ended at t ' +
      t.toFixed(2) + ' s: this is its final state';
  });
  source.onerror = () => {
    if (body.dataset.moaStatus !== 'ended') {
      status.textContent = 'no connection to moa live (the run may have ended), retrying';
    }
  };
})();
