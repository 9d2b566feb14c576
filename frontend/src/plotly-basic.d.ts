// plotly.js-basic-dist-min ships no types; its API is the full bundle's (a subset of trace types).
declare module "plotly.js-basic-dist-min" {
  import Plotly from "plotly.js-dist-min";
  export default Plotly;
}
