#include "render/plot.hpp"

#include <vtkAxis.h>
#include <vtkChartLegend.h>
#include <vtkChartMatrix.h>
#include <vtkChartXY.h>
#include <vtkContextScene.h>
#include <vtkContextView.h>
#include <vtkDoubleArray.h>
#include <vtkNew.h>
#include <vtkObject.h>
#include <vtkPNGWriter.h>
#include <vtkPen.h>
#include <vtkPlotLine.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkTable.h>
#include <vtkTextProperty.h>
#include <vtkVector.h>
#include <vtkWindowToImageFilter.h>

#include <filesystem>
#include <unistd.h>

#include "pipeline/error.hpp"
#include "render/render.hpp"
#include "render/virtual_display.hpp"

namespace hedgefit::render {

void PlotErrors(const std::vector<ErrorSeries>& series, const std::string& x_title, int width, int height,
                const std::string& png_path) {
  namespace fs = std::filesystem;
  const fs::path target(png_path);
  std::error_code ec;
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  if (!fs::is_directory(dir, ec)) throw Error(png_path + ": directory '" + dir.string() + "' does not exist; create it first");
  if (series.empty()) throw Error(png_path + ": nothing to plot; give clouds with truth (CLOUD.truth.json or --truth)");
  if (width < 100 || height < 100) throw Error("plot size: at least 100 x 100 px");
  EnsureDisplay();
  vtkObject::GlobalWarningDisplayOff();

  vtkNew<vtkContextView> view;
  view->GetRenderer()->SetBackground(1, 1, 1);
  view->GetRenderWindow()->SetOffScreenRendering(1);
  view->GetRenderWindow()->SetMultiSamples(0);
  view->GetRenderWindow()->SetSize(width, height);
  vtkNew<vtkChartMatrix> matrix;
  matrix->SetSize(vtkVector2i(2, 1));
  matrix->SetGutter(vtkVector2f(70, 60));
  view->GetScene()->AddItem(matrix);
  const char* titles[2] = {"radius error |AER| (mm)", "centre deviation LD (mm)"};
  for (int k = 0; k < 2; ++k) {
    auto* chart = vtkChartXY::SafeDownCast(matrix->GetChart(vtkVector2i(k, 0)));
    chart->SetTitle(titles[k]);
    chart->GetTitleProperties()->SetFontSize(16);
    chart->GetAxis(vtkAxis::BOTTOM)->SetTitle(x_title);
    chart->GetAxis(vtkAxis::LEFT)->SetTitle("mm");
    chart->SetShowLegend(k == 0);
    for (std::size_t i = 0; i < series.size(); ++i) {
      const ErrorSeries& s = series[i];
      if (s.x.empty()) continue;
      vtkNew<vtkTable> table;
      vtkNew<vtkDoubleArray> xs, ys;
      xs->SetName("x");
      ys->SetName(s.method.c_str());
      for (std::size_t j = 0; j < s.x.size(); ++j) {
        xs->InsertNextValue(s.x[j]);
        ys->InsertNextValue(k == 0 ? s.abs_aer_mm[j] : s.ld_mm[j]);
      }
      table->AddColumn(xs);
      table->AddColumn(ys);
      auto* line = vtkPlotLine::SafeDownCast(chart->AddPlot(vtkChart::LINE));
      line->SetInputData(table, 0, 1);
      const auto c = OverlayColor(i);
      line->SetColor(static_cast<unsigned char>(255 * c[0]), static_cast<unsigned char>(255 * c[1]),
                     static_cast<unsigned char>(255 * c[2]), 255);
      line->SetWidth(2.0);
      line->SetMarkerStyle(vtkPlotPoints::CIRCLE);
      line->SetMarkerSize(7);
    }
  }
  view->GetRenderWindow()->Render();
  WriteWindowPng(view->GetRenderWindow(), png_path);
}

}  // namespace hedgefit::render
