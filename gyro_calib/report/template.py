"""The certificate's HTML (Jinja2): self-contained, no script, no external resource, A4 print."""

TEMPLATE = r"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>Calibration certificate — gyro {{ c.gyro_id }}</title>
<style>
@page { size: A4; margin: 14mm 12mm 16mm 12mm;
        @bottom-right { content: "page " counter(page) " of " counter(pages); font-size: 8pt; }
        @bottom-left { content: "gyro {{ c.gyro_id }} — calibration certificate"; font-size: 8pt; } }
body { font-family: "DejaVu Sans", Arial, sans-serif; font-size: 9pt; color: #111; margin: 0 auto;
       max-width: 190mm; background: #fff; }
h1 { font-size: 15pt; margin: 0 0 4pt 0; }
h2 { font-size: 11.5pt; margin: 12pt 0 4pt 0; border-bottom: 1px solid #888; }
h3 { font-size: 10pt; margin: 8pt 0 3pt 0; }
table { border-collapse: collapse; width: 100%; margin: 2pt 0 6pt 0; }
th, td { border: 1px solid #bbb; padding: 1.5pt 3pt; text-align: left; vertical-align: top; }
th { background: #eee; }
td.num { text-align: right; font-family: "DejaVu Sans Mono", monospace; white-space: nowrap; }
tr, figure { page-break-inside: avoid; break-inside: avoid; }
.key { font-family: "DejaVu Sans Mono", monospace; font-size: 8pt; }
.desc { color: #444; font-size: 7.5pt; }
.hash { font-family: "DejaVu Sans Mono", monospace; font-size: 6.5pt; word-break: break-all; }
.verdict { font-weight: bold; padding: 0 3pt; }
.PASS { color: #0a6b1f; } .FAIL { color: #b00000; } .CONDITIONAL { color: #a05a00; }
.overall { font-size: 13pt; border: 2px solid; padding: 3pt 8pt; display: inline-block; }
figure { margin: 6pt 0; }
figure img { max-width: 100%; height: auto; display: block; }
figcaption { font-size: 8pt; color: #333; }
pre { font-size: 7pt; white-space: pre-wrap; background: #f6f6f6; padding: 3pt; }
.small { font-size: 7.5pt; }
</style>
</head>
<body>
<h1>Calibration certificate — gyro {{ c.gyro_id }}</h1>
{% if c.overall %}<p>Verdict of the unit: <span class="overall verdict {{ c.overall }}" id="overall">{{ c.overall }}</span></p>{% endif %}

<h2>Identity and conditions</h2>
<table id="identity">
<tr><th>gyro id</th><td>{{ c.gyro_id }}</td></tr>
<tr><th>calibrated (UTC)</th><td>{{ c.calibrated_utc }}</td></tr>
<tr><th>certificate issued (UTC)</th><td>{{ c.issued_utc }}</td></tr>
<tr><th>software</th><td>{{ c.software }}</td></tr>
<tr><th>hand-off file</th><td class="key">{{ c.handoff_path }}</td></tr>
<tr><th>complete</th><td>{{ 'yes: every quantity the methods that ran measure was measured' if c.complete else 'no: see "Not measured"' }}</td></tr>
<tr><th>site latitude</th><td>{{ c.latitude }}</td></tr>
</table>
{% if c.evidence_note %}<p><b>Note:</b> {{ c.evidence_note }}</p>{% endif %}

<h3>Inputs</h3>
{% if c.bags %}
<table id="inputs"><tr><th>bag</th><th>file</th><th>SHA-256</th><th>data span</th></tr>
{% for b in c.bags %}<tr><td class="key">{{ b[0] }}</td><td class="key">{{ b[1] }}</td><td class="hash">{{ b[2] }}</td><td class="small">{{ b[3] }}</td></tr>
{% endfor %}</table>
{% else %}<p>The input bags were not given to the report; each method's source below is as the hand-off file records it.</p>{% endif %}
{% if c.settings %}
<h3>Bench settings used</h3>
<table id="settings"><tr><th>method</th><th>setting</th><th>value</th><th>where it came from</th></tr>
{% for s in c.settings %}<tr><td>{{ s[0] }}</td><td class="key">{{ s[1] }}</td><td>{{ s[2] }}</td><td class="small">{{ s[3] }}</td></tr>
{% endfor %}</table>
{% endif %}

<h2>Results</h2>
<p class="small">Standard uncertainty u (k = 1); expanded uncertainty U = k·u with k for a 95 % coverage probability from the effective degrees of freedom ν (Student t, Welch–Satterthwaite; GUM G.3, G.4); n: the independent measurements (windows, pairs, stations, segments …) the value rests on.</p>
<table id="results">
<tr><th>quantity</th><th>value</th><th>u</th><th>unit</th><th>n</th><th>ν</th><th>k</th><th>U</th>{% if c.rule %}<th>limits</th><th>verdict</th>{% endif %}</tr>
{% for r in c.rows %}<tr class="quantity" data-key="{{ r.key }}" data-value-si="{{ '%r' % r.value_si }}" data-std-si="{{ '%r' % r.std_si }}">
<td><span class="key">{{ r.key }}</span>{% if not r.in_handoff %} <span class="desc">(not in the hand-off)</span>{% endif %}<br><span class="desc">{{ r.description }}</span>{% if r.note %}<br><span class="desc">{{ r.note }}</span>{% endif %}</td>
<td class="num value">{{ r.value }}</td><td class="num std">{{ r.std }}</td><td>{{ r.unit }}</td><td class="num">{{ r.n }}</td><td class="num">{{ r.dof }}</td><td class="num k">{{ r.k }}</td><td class="num U">{{ r.expanded }}</td>
{% if c.rule %}<td class="small">{{ r.limit or '—' }}</td><td>{% if r.verdict %}<span class="verdict {{ r.verdict }}">{{ r.verdict }}</span>{% else %}—{% endif %}</td>{% endif %}</tr>
{% endfor %}</table>
{% if c.facts %}<h3>Counts and facts</h3>
<table id="facts">{% for f in c.facts %}<tr><td class="key">{{ f[0] }}</td><td>{{ f[1] }}</td><td class="desc">{{ f[2] }}</td></tr>{% endfor %}</table>{% endif %}
{% for m in c.mappings %}<h3>{{ m[0] }}</h3><p class="desc">{{ m[1] }}</p><pre>{{ m[2] }}</pre>{% endfor %}

<h2>Acceptance</h2>
{% if c.rule %}
<p>Specification: <span class="key">{{ c.spec_source }}</span>. Decision rule {{ c.rule }}. Verdict of the unit: <span class="verdict {{ c.overall }}">{{ c.overall }}</span> (FAIL if any quantity fails; CONDITIONAL if any is conditional, or not measured by a method that ran).</p>
{% if c.spec_missing %}<ul>{% for s in c.spec_missing %}<li>{{ s }}</li>{% endfor %}</ul>{% endif %}
{% else %}<p id="no-spec">No specification was given (<span class="key">--spec</span>): this certificate states no verdicts.</p>{% endif %}

<h2>Uncertainty budgets</h2>
<p class="small">Each source's standard uncertainty, its degrees of freedom and its share of u²; combined in GTC (the GUM Tree Calculator).</p>
{% for r in c.rows %}<table class="budget" data-key="{{ r.key }}"><tr><th colspan="4"><span class="key">{{ r.key }}</span> — u = {{ r.std }} {{ r.unit }}; {{ r.k_note }}</th></tr>
{% if r.budget %}<tr><th>source</th><th>u ({{ r.unit }})</th><th>ν</th><th>share of u²</th></tr>
{% for b in r.budget %}<tr><td>{{ b[0] }}</td><td class="num">{{ b[1] }}</td><td class="num">{{ b[2] }}</td><td class="num">{{ b[3] }}</td></tr>{% endfor %}
{% else %}<tr><td colspan="4">The sources of u are not known to this certificate (no data given).</td></tr>{% endif %}</table>
{% endfor %}

<h2>Methods</h2>
{% for m in c.methods %}<section class="method" id="method-{{ m.name }}">
<h3>{{ m.name }} — {{ m.title }}</h3>
<table><tr><th>source</th><td class="key">{{ m.source }}</td></tr><tr><th>data span</th><td>{{ m.span }}</td></tr><tr><th>calculated (UTC)</th><td>{{ m.created_utc }}</td></tr></table>
{% if m.summary %}<ul class="small">{% for s in m.summary %}<li>{{ s }}</li>{% endfor %}</ul>{% endif %}
<p><b>Not measured:</b> {% if m.missing %}</p><ul>{% for k, why in m.missing %}<li><span class="key">{{ k }}</span>: {{ why }}</li>{% endfor %}</ul>{% else %}nothing.</p>{% endif %}
<p><b>Rejections:</b> {{ m.rejections|length + m.rejections_more }}{% if not m.rejections and not c.bags %} (not known: no bag given){% endif %}</p>
{% if m.rejections %}<ul class="small">{% for r in m.rejections %}<li>{{ r }}</li>{% endfor %}{% if m.rejections_more %}<li>… and {{ m.rejections_more }} more (all are listed by gyro-calib calibrate and its --json).</li>{% endif %}</ul>{% endif %}
{% if m.notices %}<p><b>Notices:</b></p><ul class="small">{% for n in m.notices %}<li>{{ n }}</li>{% endfor %}</ul>{% endif %}
{% for f in m.figures %}<figure data-figure="{{ f[0] }}"><img src="{{ f[2] }}" alt="{{ f[1] }}"><figcaption>{{ f[1] }}</figcaption></figure>{% endfor %}
</section>{% endfor %}
{% if c.notes %}<h2>Notes</h2><ul>{% for n in c.notes %}<li>{{ n }}</li>{% endfor %}</ul>{% endif %}
<p class="small">Values are those of the hand-off file, shown in the units quoted; the hand-off file holds them in SI with their standard uncertainties. Generated by gyro-calib report.</p>
</body>
</html>
"""
