// Drives headless Chromium (Debian's, through playwright-core, pinned in
// package-lock.json) over a tetopt HTML report and checks its 3D view.
// Called by test_view3d.sh; prints "ok ..." / "FAIL ..." lines, exits 1 on
// any failure.
//   node view3d_check.mjs PAGE.html SHOT.png [click] [sets=a,b] [before=N] [after=N]
//   click: click the first row of the worst-tets table (the camera flies to
//          the tet), then the tet itself in the canvas, and expect the
//          panel to show that tet's row of the table.
//   sets:  the names of the view's sets (before,after for improve).
//   before=N / after=N: the number of poor tets each set must show.
import { chromium } from 'playwright-core';

const [page_path, shot, ...rest] = process.argv.slice(2);
const opts = Object.fromEntries(rest.map((a) => (a.includes('=') ? a.split('=') : [a, true])));
let failed = 0;
const check = (name, ok, detail = '') => {
  console.log((ok ? 'ok   ' : 'FAIL ') + name + (detail ? ' (' + detail + ')' : ''));
  if (!ok) failed = 1;
};

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  // Headless WebGL through ANGLE's software renderer (SwiftShader).
  args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
    '--disable-background-networking', '--host-resolver-rules=MAP * ~NOTFOUND'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1200, height: 1000 } });
  const errors = [], foreign = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('request', (r) => { if (!/^(file|blob|data):/.test(r.url())) foreign.push(r.url()); });
  await page.goto('file://' + page_path);
  let ready = null;
  try {
    await page.waitForFunction(() => document.documentElement.getAttribute('data-view-ready'), null, { timeout: 30000 });
    ready = await page.evaluate(() => document.documentElement.getAttribute('data-view-ready'));
  } catch (e) { /* reported below */ }
  check('the view drew its first frame', ready === '1', 'data-view-ready=' + ready);
  const ms = await page.evaluate(() => document.documentElement.getAttribute('data-view-ms'));
  console.log('info first frame at ' + ms + ' ms');

  // The canvas is drawn: the screenshot of the view differs from its
  // background colour (#f5f7fa) in many pixels and has many colours.
  const canvas = page.locator('#tv-canvas');
  await canvas.screenshot({ path: shot });
  const png = (await canvas.screenshot()).toString('base64');
  const stats = await page.evaluate(async (b64) => {
    const img = new Image();
    img.src = 'data:image/png;base64,' + b64;
    await img.decode();
    const c = document.createElement('canvas');
    c.width = img.width; c.height = img.height;
    const g = c.getContext('2d');
    g.drawImage(img, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let differ = 0;
    const colours = new Set();
    for (let i = 0; i < d.length; i += 4) {
      if (Math.abs(d[i] - 0xf5) > 12 || Math.abs(d[i + 1] - 0xf7) > 12 || Math.abs(d[i + 2] - 0xfa) > 12) differ++;
      colours.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
    }
    return { w: c.width, h: c.height, differ: differ / (d.length / 4), colours: colours.size };
  }, png);
  check('the canvas is drawn (pixels differ from the background)', stats.differ > 0.05 && stats.colours > 20,
    `${stats.w}x${stats.h}, ${(100 * stats.differ).toFixed(1)}% differ, ${stats.colours} colours`);

  // Rotating changes the picture.
  const box = await canvas.boundingBox();
  const hash = async () => (await canvas.screenshot()).toString('base64');
  const before_drag = await hash();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width / 2 + 120, box.y + box.height / 2 + 40, { steps: 6 });
  await page.mouse.up();
  await page.waitForTimeout(200);
  check('dragging rotates the view', (await hash()) !== before_drag);

  if (opts.sets) {
    const sets = await page.evaluate(() => window.tetoptView.sets.join(','));
    check('the view has the sets ' + opts.sets, sets === opts.sets, sets);
  }
  for (const name of ['before', 'after', 'mesh']) {
    if (opts[name] === undefined) continue;
    const radio = page.locator('input[name="tv-set"][value="' + (name === 'before' ? 0 : 1) + '"]');
    if (await radio.count()) await radio.check();
    const [set, shown] = await page.evaluate(() => [window.tetoptView.set, window.tetoptView.shown()]);
    check(`the ${name} toggle shows ${opts[name]} poor tets`, set === name && shown === +opts[name], `${set}: ${shown}`);
  }

  if (opts.click) {
    const row = page.locator('#worst tr[data-tet]').first();
    const id = +(await row.getAttribute('data-tet'));
    const cells = await row.locator('td').allInnerTexts();
    await row.click();
    await page.waitForFunction(() => document.documentElement.getAttribute('data-view-flying') === '0', null, { timeout: 10000 });
    // The smooth scroll that brings the view into sight: wait until it rests.
    let box = await canvas.boundingBox();
    for (let i = 0; i < 50; ++i) {
      await page.waitForTimeout(100);
      const b = await canvas.boundingBox();
      if (b.x === box.x && b.y === box.y) break;
      box = b;
    }
    const p = await page.evaluate((i) => window.tetoptView.screenOf(i), id);
    const inside = p && p.x > box.x && p.x < box.x + box.width && p.y > box.y && p.y < box.y + box.height;
    check('clicking a table row flies the camera to its tet', !!inside && Math.hypot(p.x - (box.x + box.width / 2), p.y - (box.y + box.height / 2)) < 5,
      p ? `tet at ${p.x.toFixed(0)},${p.y.toFixed(0)}, view centre ${(box.x + box.width / 2).toFixed(0)},${(box.y + box.height / 2).toFixed(0)}` : 'not in the view');
    // Empty the panel (a click beside the tet), then click the tet itself.
    await page.mouse.click(box.x + 3, box.y + 3);
    const shown_before = await page.evaluate(() => document.querySelector('#tv-row tr[data-tet]')?.dataset.tet ?? null);
    check('a click beside the tet does not show its row', shown_before !== String(id), 'panel: ' + shown_before);
    await page.mouse.click(p.x, p.y);
    const got = await page.evaluate(() => {
      const tr = document.querySelector('#tv-row tr[data-tet]');
      return tr ? { id: tr.dataset.tet, cells: [...tr.querySelectorAll('td')].map((td) => td.innerText) } : null;
    });
    check('clicking tet ' + (id + 1) + ' shows its row of the table', got && got.id === String(id) &&
      JSON.stringify(got.cells) === JSON.stringify(cells), got ? got.cells.join(' | ') : 'no row shown');
  }
  if (opts.click) {
    // A tet the table does not list shows a row built from the view's data:
    // for every listed tet that row must match the table's (the centroid,
    // from float32 corners, to 6 significant digits give or take one unit).
    const rows = await page.evaluate(() => [...document.querySelectorAll('#worst tr[data-tet]')].map((tr) =>
      ({ id: +tr.dataset.tet, cells: [...tr.querySelectorAll('td')].map((td) => td.textContent),
        data: window.tetoptView.rowFromData(+tr.dataset.tet) })));
    const bad = rows.filter((r) => !r.data || r.data.length !== r.cells.length || r.cells.some((c, i) =>
      i < 7 ? c !== r.data[i] : Math.abs(+c - +r.data[i]) > 1.5e-5 * Math.max(1, Math.abs(+c))));
    check(`the view's own rows match the table's (${rows.length} rows)`, rows.length > 0 && bad.length === 0,
      bad.length ? JSON.stringify(bad[0]) : '');
  }
  check('no console error', errors.length === 0, errors.join(' / ').slice(0, 500));
  check('no request outside the page', foreign.length === 0, foreign.join(' ').slice(0, 300));
} finally {
  await browser.close();
}
process.exit(failed);
