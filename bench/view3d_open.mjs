// Opens a tetopt HTML report in headless Chromium (Debian's /usr/bin/chromium
// through playwright-core) and measures how long its 3D view takes to draw.
//   node bench/view3d_open.mjs PAGE.html [runs=N] [shot=FILE.png] [set=before|after|mesh]
//        [measure=alpha|dmin|dmax|cls] [clip=0|1|2 at=0..1000] [opacity=0..100]
// Prints, per run and as the median over the runs:
//   open: from page.goto() to data-view-ready="1" on <html> (the first frame
//         of the view drawn), wall clock in this process;
//   first frame: performance.now() at that frame (from the navigation's start),
//         with the stages of src/view3d.js (data-view-stages).
// shot: a PNG of the view (#view3d: canvas, controls, legend) after the last
// run, with the set, colouring, clipping plane and opacity given.
// WebGL runs on SwiftShader (no GPU here): a machine with a GPU draws faster.
import { chromium } from 'playwright-core';

const [page_path, ...rest] = process.argv.slice(2);
const opt = Object.fromEntries(rest.map((a) => a.split('=')));
const runs = +(opt.runs || 3);
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
const open = [], first = [];
let page;
for (let r = 0; r < runs; ++r) {
  const ctx = await browser.newContext({ viewport: { width: 1200, height: 1000 } });
  page = await ctx.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  const t0 = performance.now();
  await page.goto('file://' + page_path, { waitUntil: 'commit' });
  await page.waitForFunction(() => document.documentElement.getAttribute('data-view-ready') === '1', null,
    { timeout: 120000, polling: 10 });
  const t1 = performance.now();
  const ms = +(await page.evaluate(() => document.documentElement.getAttribute('data-view-ms')));
  const stages = await page.evaluate(() => document.documentElement.getAttribute('data-view-stages'));
  open.push(t1 - t0);
  first.push(ms);
  console.log(`run ${r + 1}: open ${(t1 - t0).toFixed(0)} ms, first frame at ${ms} ms (stages, ms from navigation: ${stages})` + (errors.length ? ', errors: ' + errors.join(' / ') : ''));
  if (r < runs - 1) await ctx.close();
}
const median = (a) => [...a].sort((x, y) => x - y)[Math.floor(a.length / 2)];
console.log(`median of ${runs}: open ${median(open).toFixed(0)} ms, first frame at ${median(first).toFixed(0)} ms`);
if (opt.shot) {
  if (opt.set) {
    await page.evaluate((name) => {
      const k = window.tetoptView.sets.indexOf(name);
      const r = document.querySelector('input[name="tv-set"][value="' + k + '"]');
      if (r) r.click();
    }, opt.set);
  }
  if (opt.measure) await page.selectOption('#tv-measure', opt.measure);
  if (opt.clip) {
    await page.selectOption('#tv-clip', opt.clip);
    if (opt.at) await page.locator('#tv-clip-at').fill(opt.at);
  }
  if (opt.opacity) await page.locator('#tv-opacity').fill(opt.opacity);
  await page.waitForTimeout(300);
  await page.locator('#view3d').screenshot({ path: opt.shot });
  console.log('wrote ' + opt.shot);
}
await browser.close();
