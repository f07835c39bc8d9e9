// aerovo's DJI SRT reader on the real SRT files of several DJI aircraft that dji_srt_parser (an
// independent JavaScript parser, npm dji_srt_parser 1.2.4, JuanIrache/DJI_SRT_Parser) ships in its
// samples/ folder, installed by run_e2e.sh. Each file aerovo reads is compared, subtitle by
// subtitle, with dji_srt_parser's raw reading of it (rawMetadata: the values as written), never
// with aerovo's own code:
//   node dji_srt.cjs AEROVO SAMPLES_DIR
//  - time_s = the subtitle's start (TIMECODE); frame = FrameCnt - 1;
//  - latitude, longitude: GPS(longitude, latitude, satellites) of the 1 Hz families (the order
//    these files write: docs/inputs.md "DJI .SRT families"), or [latitude] [longtitude|longitude];
//    0, 0 or N/A is a record without a fix (empty cells);
//  - rel_alt = BAROMETER, H, rel_alt, else Hb; abs_alt = altitude or abs_alt; yaw = F.PRY's yaw;
//    gimbal pitch = G.PRY's pitch; focal_35mm = focal_len (tenths of a mm when >= 100);
//  - each value to the precision aerovo prints (`aerovo telemetry --print`).
// The files aerovo does not read as a whole are checked for what it says instead: the cut last
// subtitle of broken_incomplete.SRT dropped with a warning, the damaged middle of
// broken_incomplete2.SRT an error naming its line (lenient: skipped), a file that records no
// position (mavic_air.SRT) read as records without a fix, the empty files and the timing-less
// mavic_2_style.SRT errors naming the file.
// Exit 0 = pass, 1 = fail (the reasons printed).
'use strict';
const fs = require('fs');
const path = require('path');
const { spawnSync } = require('child_process');
const DJISRTParser = require('dji_srt_parser');
const { failures, check, finish } = require('./harness.cjs');

const [aerovo, samples] = process.argv.slice(2);

function telemetry(file, extra = []) {
  const r = spawnSync(aerovo, ['telemetry', '--print', ...extra, file], { encoding: 'utf8' });
  const lines = r.stdout.split('\n');
  const head = lines.findIndex(l => l.startsWith('time_s,'));
  let rows = [];
  if (head >= 0) {
    const cols = lines[head].split(',');
    rows = lines.slice(head + 1).filter(l => l).map(l => {
      const c = l.split(','); const o = {};
      cols.forEach((h, i) => { o[h] = c[i]; });
      return o;
    });
  }
  return { status: r.status, err: r.stderr, rows };
}

const clock = t => {  // "HH:MM:SS,mmm"
  const m = /^(\d+):(\d+):(\d+)[,.](\d+)/.exec(t);
  return m ? ((+m[1]) * 60 + (+m[2])) * 60 + (+m[3]) + (+m[4]) / 1000 : NaN;
};
const first = (...v) => v.find(x => x !== undefined && x !== null && x !== '');

// What aerovo must print for one raw packet of dji_srt_parser.
function expected(p) {
  const e = { t: clock(p.TIMECODE) };
  if (Array.isArray(p.GPS)) {
    [e.lon, e.lat] = p.GPS;
  } else if (p.latitude !== undefined) {
    e.lat = p.latitude;
    e.lon = first(p.longtitude, p.longitude);
  }
  // No fix yet: 0, 0, or "N/A" (mavic_pro_buggy.SRT's GPS(N/A,N/A,6)).
  if ((e.lat === 0 && e.lon === 0) || e.lat === 'N/A' || e.lon === 'N/A') e.lat = e.lon = undefined;
  e.rel = first(p.BAROMETER, p.H, p.rel_alt, p.Hb);
  e.abs = first(p.altitude, p.abs_alt);
  if (p.FrameCnt !== undefined) e.frame = p.FrameCnt - 1;
  if (Array.isArray(p.F_PRY)) e.yaw = p.F_PRY[2];
  if (Array.isArray(p.G_PRY)) e.gpitch = p.G_PRY[0];
  if (p.focal_len !== undefined) e.focal = p.focal_len >= 100 ? p.focal_len / 10 : p.focal_len;
  return e;
}

function compare(name, packets, rows) {
  if (!check(rows.length === packets.length,
    `${name}: ${rows.length} samples read, dji_srt_parser reads ${packets.length}`)) return 0;
  let positions = 0;
  packets.forEach((p, i) => {
    const e = expected(p), r = rows[i];
    const where = `${name} subtitle ${i + 1}`;
    const near = (what, got, want, tol) => {
      if (want === undefined) {
        check(got === '' || got === undefined, `${where}: ${what} '${got}', none in the file`);
      } else {
        check(got !== '' && Math.abs(Number(got) - Number(want)) <= tol,
          `${where}: ${what} '${got}', the file says ${want}`);
      }
    };
    near('time_s', r.time_s, e.t, 0.0005);
    near('lat_deg', r.lat_deg, e.lat, 0.6e-8);
    near('lon_deg', r.lon_deg, e.lon, 0.6e-8);
    near('rel_alt_m', r.rel_alt_m, e.rel, 0.0006);
    near('abs_alt_m', r.abs_alt_m, e.abs, 0.0006);
    near('frame', r.frame, e.frame, 0);
    near('yaw_deg', r.yaw_deg, e.yaw, 0.006);
    near('gimbal_pitch_deg', r.gimbal_pitch_deg, e.gpitch, 0.006);
    near('focal_35mm_mm', r.focal_35mm_mm, e.focal, 0.06);
    if (e.lat !== undefined) ++positions;
  });
  return positions;
}

async function main() {
  const files = fs.readdirSync(samples).filter(f => /\.srt$/i.test(f)).sort();
  check(files.length >= 14, `only ${files.length} SRT files in ${samples}`);
  const special = {
    'broken_empty.SRT': f => {
      const t = telemetry(f);
      check(t.status === 1 && t.err.includes('no telemetry samples'), `${f}: ${t.status} ${t.err}`);
    },
    'broken_empty2.SRT': f => {
      const t = telemetry(f);
      check(t.status === 1 && t.err.includes('broken_empty2.SRT'), `${f}: ${t.status} ${t.err}`);
    },
    'broken_incomplete.SRT': f => {
      // The recording stopped inside subtitle 20 (after its HOME line): dropped with a warning.
      const raw = DJISRTParser(fs.readFileSync(f, 'utf8'), f).rawMetadata();
      const t = telemetry(f);
      check(t.status === 0, `${f}: exit ${t.status}: ${t.err}`);
      check(t.err.includes('the last subtitle (20) is cut short'), `${f}: no cut warning: ${t.err}`);
      check(raw.length === 20 && raw[19].GPS === undefined, `${f}: dji_srt_parser's last packet has a GPS`);
      compare(path.basename(f), raw.slice(0, 19), t.rows);
    },
    'broken_incomplete2.SRT': f => {
      // Subtitle 3's line is cut in the middle of the file: strict names it, lenient skips it
      // (and drops the cut last subtitle 6).
      const strict = telemetry(f);
      check(strict.status === 1 && strict.err.includes("broken_incomplete2.SRT:17: unclosed '['"),
        `${f}: strict ${strict.status}: ${strict.err}`);
      const lenient = telemetry(f, ['--lenient']);
      check(lenient.status === 0 && lenient.rows.length === 4,
        `${f}: lenient ${lenient.status}, ${lenient.rows.length} samples: ${lenient.err}`);
    },
    'mavic_2_style.SRT': f => {
      // Dates in place of the timing lines: not an SRT timing, an error naming the line.
      const t = telemetry(f);
      check(t.status === 1 && t.err.includes('mavic_2_style.SRT:2: bad timing line'),
        `${f}: ${t.status} ${t.err}`);
    },
    'mavic_air.SRT': f => {
      const raw = DJISRTParser(fs.readFileSync(f, 'utf8'), f).rawMetadata();
      const t = telemetry(f);
      check(t.status === 0, `${f}: exit ${t.status}: ${t.err}`);
      check(raw.every(p => p.latitude === undefined && p.GPS === undefined),
        `${f}: dji_srt_parser finds a position`);
      compare(path.basename(f), raw, t.rows);
    },
  };
  let read = 0, subtitles = 0, positions = 0;
  for (const name of files) {
    const f = path.join(samples, name);
    if (special[name]) {
      special[name](f);
      continue;
    }
    const raw = DJISRTParser(fs.readFileSync(f, 'utf8'), name).rawMetadata();
    const t = telemetry(f);
    if (!check(t.status === 0, `${name}: exit ${t.status}: ${t.err.slice(0, 400)}`)) continue;
    positions += compare(name, raw, t.rows);
    subtitles += raw.length;
    ++read;
  }
  check(read >= 8, `only ${read} sample files compared`);
  console.log(`${read} DJI SRT files compared with dji_srt_parser (${subtitles} subtitles, ` +
    `${positions} with a position); ${Object.keys(special).length} checked for their errors`);
}

finish(main, 30);
