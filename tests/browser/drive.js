// Drive the rrps viewer in headless Chromium like a person: node drive.js URL STEPS_JSON
// STEPS_JSON is a list of steps, run in order:
//   {"wait_text": "text", "timeout": ms}     wait until the page shows the text
//   {"screenshot": "/tmp/file.png"}           save a screenshot
//   {"fill": "Token", "value": "..."}         type into the text input with that label
//   {"click": "Button label"}                  click a button by its visible name
//   {"check": "Checkbox label"}                click the checkbox with that label
//   {"hold": "Button label", "ms": 1500}        press the mouse on a button, hold, release
//   {"sleep": ms}
//   {"sync": "name"}                           print {"sync": name}, wait for a line on stdin
//   {"disabled": "Button label"}               record whether the button is disabled
//   {"text": true}                             record the page's visible text
// Any step may carry "page": N to act on the N-th page (each page is a separate viewer client);
// wait_text, fill, check and click take "timeout": ms.
// Prints one JSON object: {"ok": true, "results": [...]} or {"ok": false, "error": "..."}.
const { chromium } = require('playwright-core');
const readline = require('readline');

const stdinLines = readline.createInterface({ input: process.stdin })[Symbol.asyncIterator]();

async function main() {
  const [url, stepsJson] = process.argv.slice(2);
  const steps = JSON.parse(stepsJson);
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    args: ['--no-sandbox', '--disable-gpu', '--enable-unsafe-swiftshader', '--disable-quic',
           '--no-first-run', '--disable-background-networking', '--disable-component-update',
           '--disable-sync'],
  });
  const results = [];
  try {
    const t0 = Date.now();
    const pages = {};
    for (const step of steps) {
      // Each step acts on page 1 unless it names another ("page": 2): two browsers at once.
      const id = step.page || 1;
      if (pages[id] === undefined) {
        pages[id] = await browser.newPage({ viewport: { width: 860, height: 600 } });
        await pages[id].goto(url);
      }
      const page = pages[id];
      const before = results.length;
      if (step.wait_text !== undefined) {
        await page.getByText(step.wait_text, { exact: false }).first()
          .waitFor({ timeout: step.timeout || 20000 });
        results.push({ wait_text: step.wait_text });
      } else if (step.screenshot !== undefined) {
        await page.screenshot({ path: step.screenshot });
        results.push({ screenshot: step.screenshot });
      } else if (step.fill !== undefined) {
        // viser renders a label next to its input: the first input after the label's text.
        await page.locator(`xpath=//*[normalize-space(text())="${step.fill}"]/following::input[1]`)
          .first().fill(step.value, { timeout: step.timeout || 30000 });
        results.push({ fill: step.fill });
      } else if (step.check !== undefined) {
        await page.locator(`xpath=//*[normalize-space(text())="${step.check}"]/following::input[@type="checkbox"][1]`)
          .first().click({ timeout: step.timeout || 10000 });
        results.push({ check: step.check });
      } else if (step.click !== undefined) {
        const button = page.getByRole('button', { name: step.click, exact: true });
        await button.click({ timeout: step.timeout || 10000, force: step.force !== false });
        results.push({ click: step.click });
      } else if (step.hold !== undefined) {
        const button = page.getByRole('button', { name: step.hold, exact: true });
        const box = await button.boundingBox();
        await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
        await page.mouse.down();
        await page.waitForTimeout(step.ms || 1000);
        await page.mouse.up();
        results.push({ hold: step.hold, ms: step.ms || 1000 });
      } else if (step.sync !== undefined) {
        // Hand over to the test (it changes something), continue when it writes a line.
        console.log(JSON.stringify({ sync: step.sync }));
        await stdinLines.next();
        results.push({ sync: step.sync });
      } else if (step.sleep !== undefined) {
        await page.waitForTimeout(step.sleep);
      } else if (step.disabled !== undefined) {
        const button = page.getByRole('button', { name: step.disabled, exact: true });
        results.push({ disabled: step.disabled, value: await button.isDisabled() });
      } else if (step.text !== undefined) {
        results.push({ text: await page.innerText('body') });
      } else {
        throw new Error('unknown step ' + JSON.stringify(step));
      }
      if (results.length > before) results[results.length - 1].ms = Date.now() - t0;
    }
    console.log(JSON.stringify({ ok: true, results }));
  } catch (err) {
    console.log(JSON.stringify({ ok: false, error: String(err), results }));
  } finally {
    await browser.close();
    process.exit(0);
  }
}

main();
