// The report page's script (audit/src/report_html.cpp embeds it in every page).

// Marks the page once every image has decoded and every plot is laid out; the report test reads it.
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.querySelectorAll('img'));
  var okImgs = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  var plots = Array.prototype.slice.call(document.querySelectorAll('.plot svg'));
  var okPlots = plots.filter(function (s) {
    var r = s.getBoundingClientRect();
    return r.width > 50 && r.height > 50;
  }).length;
  document.body.setAttribute('data-render-check',
    'images ' + okImgs + '/' + imgs.length + ' plots ' + okPlots + '/' + plots.length);
});

// The source/candidate comparison: the slider sets the split (percent of the width from the left at which the
// candidate begins), flip jumps between all candidate (0) and all source (100). Delegated, so no set-up is needed.
function rgsSetSplit(box, v) {
  v = Math.max(0, Math.min(100, Number(v)));
  box.querySelector('img.over').style.clipPath = 'inset(0 0 0 ' + v + '%)';
  box.querySelector('.divider').style.left = v + '%';
  box.querySelector('input.slider').value = v;
  box.setAttribute('data-split', String(v));
}
document.addEventListener('input', function (e) {
  if (!e.target.classList || !e.target.classList.contains('slider')) return;
  rgsSetSplit(e.target.closest('.compare'), e.target.value);
});
document.addEventListener('click', function (e) {
  if (!e.target.classList || !e.target.classList.contains('flip')) return;
  var box = e.target.closest('.compare');
  rgsSetSplit(box, Number(box.getAttribute('data-split')) > 0 ? 0 : 100);
});
