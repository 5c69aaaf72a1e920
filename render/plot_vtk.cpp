// libhedgefit_vtk.so's charts (render/vtk_module.hpp): fit errors drawn with VTK's charts and
// written to PNG. plot.cpp checks the request and calls in here.

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

#include <cstdio>
#include <exception>

#include "pipeline/error.hpp"
#include "render/render.hpp"
#include "render/virtual_display.hpp"
#include "render/vtk_module.hpp"

namespace hedgefit::render {

namespace {

void DrawPlot(const std::vector<ErrorSeries>& series, const std::string& x_title, int width, int height,
              const std::string& png_path) {
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

}  // namespace
}  // namespace hedgefit::render

extern "C" int hedgefit_vtk_plot_errors_v1(const std::vector<hedgefit::render::ErrorSeries>* series, const char* x_title,
                                            int width, int height, const char* png_path, char* why, std::size_t why_size) {
  try {
    hedgefit::render::DrawPlot(*series, x_title, width, height, png_path);
    return 0;
  } catch (const std::exception& e) {
    std::snprintf(why, why_size, "%s", e.what());
    return 1;
  }
}
