// Drive the rrps viewer in headless Chromium like a person: node drive.js URL STEPS_JSON
// STEPS_JSON is a list of steps, run in order:
//   {"wait_text": "text"}                      wait until the page shows the text
//   {"screenshot": "/tmp/file.png"}            save a screenshot
//   {"screenshot": "/tmp/f.png", "sync": "n"}  save one, then sync: a reply "again" takes another
//   {"fill": "Token", "value": "..."}          type into the text input with that label
//   {"click": "Button label", "expect": "text"} click a button by its visible name once it is
//                                              visible and enabled; with "expect", click again
//                                              if the text did not show (the click was lost)
//   {"click": "Button label", "force": true}   click even a disabled button (nothing may happen)
//   {"check": "Checkbox label"}                tick the checkbox with that label
//   {"hold": "Button label", "ms": 1500}       press the mouse on a button, hold, release
//   {"press": "Button label"}, {"release": true}  press the mouse on a button / let it go
//   {"sleep": ms}
//   {"sync": "name"}                           print {"sync": name}, wait for a line on stdin
//   {"disabled": "Button label"}               record whether the button is disabled
//   {"text": true}                             record the page's visible text
//   {"css": "canvas { display: none; }"}       add a style sheet to the page
//   {"close": true}                            close the page (its client disconnects)
// Any step may carry "page": N to act on the N-th page (each page is a separate viewer client,
// opened by its first step).
// Prints one JSON object: {"ok": true, "results": [...]} or {"ok": false, "error": "..."}.
//
// Every wait is a deadline for something that must happen (TIMEOUT), not a duration: it ends as
// soon as the page shows the result. Two software-rendered 3-D pages on a loaded 2-core machine
// answer slowly (seconds per action), so the deadlines are generous.

// Playwright waits for document.fonts.ready before a screenshot, in a script world of its own;
// on this page that promise did not settle there within 30 s on a loaded machine (the page's
// own fonts are loaded: it uses no web fonts to wait for), so skip that wait.
process.env.PW_TEST_SCREENSHOT_NO_FONTS_READY = '1';
const { chromium } = require('playwright-core');
const readline = require('readline');

// A page load or a screenshot took 35-75 s here when other jobs kept the load average above 10.
const TIMEOUT = 120000;         // ms: deadline of any one wait or action
const CLICK_RESULT = 30000;     // ms: wait for a click's "expect" text before clicking again
const CLICK_ATTEMPTS = 3;

const stdinLines = readline.createInterface({ input: process.stdin })[Symbol.asyncIterator]();

async function sync(name) {
  // Hand over to the test (it changes or checks something), continue when it writes a line.
  console.log(JSON.stringify({ sync: name }));
  const line = await stdinLines.next();
  return line.done ? '' : line.value.trim();
}

function button(page, label) {
  return page.getByRole('button', { name: label, exact: true });
}

async function waitEnabled(locator) {
  await locator.waitFor({ state: 'visible', timeout: TIMEOUT });
  const deadline = Date.now() + TIMEOUT;
  while (!(await locator.isEnabled())) {
    if (Date.now() > deadline) throw new Error('still disabled after ' + TIMEOUT + ' ms');
    await new Promise((resolve) => setTimeout(resolve, 100));
  }
}

async function shows(page, text, timeout) {
  try {
    await page.getByText(text, { exact: false }).first().waitFor({ timeout });
    return true;
  } catch (err) {
    if (err.name === 'TimeoutError') return false;
    throw err;
  }
}

async function click(page, step) {
  const target = button(page, step.click);
  if (step.force) {
    await target.click({ force: true, timeout: TIMEOUT });
    return 1;
  }
  for (let attempt = 1; ; attempt++) {
    await waitEnabled(target);
    // Not forced: playwright waits until the button is stable and would receive the click
    // (no notification over it), so the click lands on the button.
    await target.click({ timeout: TIMEOUT });
    if (step.expect === undefined || await shows(page, step.expect, CLICK_RESULT)) return attempt;
    if (attempt >= CLICK_ATTEMPTS || !(await target.isEnabled())) {
      throw new Error(`"${step.expect}" not shown after clicking "${step.click}" ${attempt} time(s)`);
    }
  }
}

async function main() {
  const [url, stepsJson] = process.argv.slice(2);
  const steps = JSON.parse(stepsJson);
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    args: ['--no-sandbox', '--disable-gpu', '--enable-unsafe-swiftshader', '--disable-quic',
           '--no-first-run', '--disable-background-networking', '--disable-component-update',
           '--disable-sync'],
    timeout: TIMEOUT,
  });
  const results = [];
  try {
    const t0 = Date.now();
    const pages = {};
    for (const step of steps) {
      // Each step acts on page 1 unless it names another ("page": 2): two browsers at once.
      const id = step.page || 1;
      if (pages[id] === null) throw new Error(`page ${id} was closed`);
      if (pages[id] === undefined) {
        pages[id] = await browser.newPage({ viewport: { width: 860, height: 600 } });
        pages[id].setDefaultTimeout(TIMEOUT);
        pages[id].setDefaultNavigationTimeout(TIMEOUT);
        await pages[id].goto(url);
      }
      const page = pages[id];
      const before = results.length;
      if (step.wait_text !== undefined) {
        await page.getByText(step.wait_text, { exact: false }).first().waitFor({ timeout: TIMEOUT });
        results.push({ wait_text: step.wait_text });
      } else if (step.screenshot !== undefined) {
        let shots = 0;
        do {
          await page.screenshot({ path: step.screenshot, timeout: TIMEOUT });
          shots++;
        } while (step.sync !== undefined && (await sync(step.sync)) === 'again');
        results.push({ screenshot: step.screenshot, shots });
      } else if (step.fill !== undefined) {
        // viser renders a label next to its input: the first input after the label's text.
        await page.locator(`xpath=//*[normalize-space(text())="${step.fill}"]/following::input[1]`)
          .first().fill(step.value, { timeout: TIMEOUT });
        results.push({ fill: step.fill });
      } else if (step.check !== undefined) {
        const box = page.locator(
          `xpath=//*[normalize-space(text())="${step.check}"]/following::input[@type="checkbox"][1]`).first();
        let attempts = 0;
        while (!(await box.isChecked())) {
          if (++attempts > CLICK_ATTEMPTS) throw new Error(`"${step.check}" does not stay ticked`);
          await waitEnabled(box);
          await box.click({ timeout: TIMEOUT });
        }
        results.push({ check: step.check, attempts });
      } else if (step.click !== undefined) {
        const attempts = await click(page, step);
        results.push({ click: step.click, attempts });
      } else if (step.hold !== undefined || step.press !== undefined) {
        const label = step.hold !== undefined ? step.hold : step.press;
        const target = button(page, label);
        await target.waitFor({ state: 'visible', timeout: TIMEOUT });
        const box = await target.boundingBox({ timeout: TIMEOUT });
        await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
        await page.mouse.down();
        if (step.hold !== undefined) {
          await page.waitForTimeout(step.ms || 1000);
          await page.mouse.up();
          results.push({ hold: label, ms: step.ms || 1000 });
        } else {
          results.push({ press: label });
        }
      } else if (step.release !== undefined) {
        await page.mouse.up();
        results.push({ release: true });
      } else if (step.sync !== undefined) {
        await sync(step.sync);
        results.push({ sync: step.sync });
      } else if (step.sleep !== undefined) {
        await page.waitForTimeout(step.sleep);
      } else if (step.disabled !== undefined) {
        await button(page, step.disabled).waitFor({ state: 'visible', timeout: TIMEOUT });
        results.push({ disabled: step.disabled, value: await button(page, step.disabled).isDisabled() });
      } else if (step.css !== undefined) {
        await page.addStyleTag({ content: step.css });
        results.push({ css: true });
      } else if (step.layout !== undefined) {
        // where the 3-D view's canvas is and where the panel's text step.layout is: boxes in px
        const panel = page.getByText(step.layout, { exact: false }).first();
        const canvas = await page.evaluate(() => [...document.querySelectorAll('canvas')]
          .map((c) => c.getBoundingClientRect())
          .map((r) => ({ x: r.x, y: r.y, width: r.width, height: r.height }))
          .sort((a, b) => b.width * b.height - a.width * a.height)[0]);   // the largest: the 3-D view
        results.push({ layout: step.layout, canvas, panel: await panel.boundingBox({ timeout: TIMEOUT }) });
      } else if (step.text !== undefined) {
        results.push({ text: await page.innerText('body') });
      } else if (step.close !== undefined) {
        await page.close();
        pages[id] = null;
        results.push({ close: id });
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

main().catch((err) => {
  // Chromium did not start (or closing it failed): still one result line, never silence.
  console.log(JSON.stringify({ ok: false, error: 'the browser: ' + String(err), results: [] }));
  process.exit(0);
});
