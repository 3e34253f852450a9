// Screenshot of a library's index.html in headless Chromium, after clicking the burn-in header (the page sorts).
//   cd /tmp/shot && npm install @sparticuz/chromium puppeteer-core   (Chromium comes inside the npm package)
//   node screenshot.mjs file:///path/to/LIBRARY/index.html out.png
// Prints the row count, images that failed to load, and the first row before and after sorting.
import chromium from "@sparticuz/chromium";
import puppeteer from "puppeteer-core";
const [,, url, out] = process.argv;
const browser = await puppeteer.launch({
  args: chromium.args, executablePath: await chromium.executablePath(), headless: true,
  defaultViewport: { width: 1300, height: 900 },
});
const page = await browser.newPage();
await page.goto(url, { waitUntil: "load" });
const first = async () => page.$eval("tbody tr td:nth-child(2) a", (a) => a.textContent);
const broken = await page.$$eval("img", (imgs) => imgs.filter((i) => !i.complete || i.naturalWidth === 0).length);
const before = await first();
// click the burn-in header: the page sorts by it
const headers = await page.$$("th");
const texts = await Promise.all(headers.map((h) => h.evaluate((e) => e.textContent)));
const idx = texts.findIndex((t) => t.toLowerCase().includes("burn"));
await headers[idx].click();
const after = await first();
await page.screenshot({ path: out, fullPage: true });
console.log(JSON.stringify({ rows: await page.$$eval("tbody tr", (r) => r.length), broken_images: broken,
  first_row_default: before, first_row_after_sorting_by_burn_in: after }));
await browser.close();
